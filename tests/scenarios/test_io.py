"""The scenarios' one JSON writer: strict JSON, non-finite floats as null."""

import json
import math

import numpy as np
import pytest

from jaxatt.scenarios import _io


def test_write_json_turns_nan_and_inf_into_null(tmp_path):
    tree = {
        "nan": math.nan,
        "inf": math.inf,
        "values": [1.5, -math.inf, np.float64("nan"), np.float32(2.0), np.int64(3)],
        "array": np.array([0.5, np.inf]),
        "nested": {"ok": True, "none": None, "t": (np.nan, "x")},
    }
    _io.write_json(tmp_path / "m.json", tree)
    text = (tmp_path / "m.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    loaded = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert loaded == {
        "nan": None,
        "inf": None,
        "values": [1.5, None, None, 2.0, 3],
        "array": [0.5, None],
        "nested": {"ok": True, "none": None, "t": [None, "x"]},
    }


def test_write_json_refuses_a_nan_that_escapes_the_sanitizer(tmp_path, monkeypatch):
    monkeypatch.setattr(_io, "json_safe", lambda tree: tree)
    with pytest.raises(ValueError, match="Out of range float values are not JSON compliant"):
        _io.write_json(tmp_path / "m.json", {"x": math.nan})


def test_write_json_returns_what_a_reader_of_the_file_gets(tmp_path):
    # Every reproduce() returns this, so the dict a notebook reads and the file a script reads
    # agree: None where the file has null (a time that never came, computed as inf), lists
    # where the tree had tuples or arrays.
    tree = {"never": math.inf, "t": (1.0, np.float64(2.5)), "a": np.array([np.nan, 1.0])}
    returned = _io.write_json(tmp_path / "m.json", tree)
    assert returned == json.loads((tmp_path / "m.json").read_text())
    assert returned == {"never": None, "t": [1.0, 2.5], "a": [None, 1.0]}


def test_write_report_records_the_versions(tmp_path):
    # A published number carries what computed it: the report gets "versions" (jaxatt, JAX,
    # jaxlib, Equinox, diffrax, optax, NumPy, Python), in the file and in the returned dict.
    import platform

    import jax

    import jaxatt

    returned = _io.write_report(tmp_path / "m.json", {"t": math.inf})
    assert returned == json.loads((tmp_path / "m.json").read_text())
    assert returned["t"] is None
    found = returned["versions"]
    assert found["jaxatt"] == jaxatt.__version__
    assert found["jax"] == jax.__version__
    assert found["python"] == platform.python_version()
    names = {"jaxatt", "jax", "jaxlib", "equinox", "diffrax", "optax", "numpy", "python"}
    assert set(found) == names
    # A report whose numbers come from another library too names it; a missing one says so.
    other = _io.write_report(tmp_path / "o.json", {}, also=("pytest", "no-such-distribution"))
    assert other["versions"]["pytest"] == pytest.__version__
    assert other["versions"]["no-such-distribution"] == "not installed"
    with pytest.raises(ValueError, match="already has the key 'versions'"):
        _io.write_report(tmp_path / "n.json", {"versions": "mine"})
    assert not (tmp_path / "n.json").exists()


def test_write_report_records_the_xla_flags(tmp_path, monkeypatch):
    # XLA's options change how its code rounds (a tuning path can follow the rounding: the
    # demo's tuned gains differ with jaxatt.enable_small_loop_kernels), so a report says which
    # were set; "" when none.
    flags = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1000000"
    monkeypatch.setenv("XLA_FLAGS", flags)
    assert _io.write_report(tmp_path / "a.json", {})["xla_flags"] == flags
    monkeypatch.delenv("XLA_FLAGS")
    assert json.loads((tmp_path / "a.json").read_text())["xla_flags"] == flags
    assert _io.write_report(tmp_path / "b.json", {})["xla_flags"] == ""
    with pytest.raises(ValueError, match="already has the key 'xla_flags'"):
        _io.write_report(tmp_path / "c.json", {"xla_flags": "mine"})
    assert not (tmp_path / "c.json").exists()


def test_the_report_sentence_names_the_versions_and_the_xla_flags(monkeypatch):
    # report.md's last sentence carries the record the JSON report holds: every version and
    # the XLA_FLAGS as set (quoted, so a reader can paste them), or that none were.
    from jaxatt._versions import versions, versions_sentence

    flags = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1000000"
    monkeypatch.setenv("XLA_FLAGS", f"  {flags} ")
    sentence = versions_sentence()
    assert sentence.startswith("Computed with jaxatt ")
    assert all(f"{name} {version}" in sentence for name, version in versions().items())
    assert sentence.endswith(f"; XLA_FLAGS `{flags}`.")
    for unset in ("", "   "):
        monkeypatch.setenv("XLA_FLAGS", unset)
        assert versions_sentence().endswith("; XLA_FLAGS unset.")
    monkeypatch.delenv("XLA_FLAGS")
    assert versions_sentence().endswith("; XLA_FLAGS unset.")


def test_every_scenario_writes_its_numbers_before_its_figures():
    """Audit (stop 49): `reproduce` drew its figures first, so a figure that failed on a failed
    run's NaN (Yu 2022's Fig. 3: `set_ylim` of NaN) left no `metrics.json`, the one file
    that reports the failure. Read from each registered scenario's source (running them all
    is the scenario tests' job); `write_report` also records the versions (stop 60)."""
    import inspect

    from jaxatt.scenarios import REGISTRY

    for name, scenario in REGISTRY.items():
        module = inspect.getmodule(scenario.reproduce)
        source = inspect.getsource(module.reproduce)
        written = source.find("write_report(out")
        assert written >= 0, name
        for figure_call in ("_write_figures(", ".savefig(", "figures("):
            at = source.find(figure_call)
            assert at < 0 or written < at, f"{name}: {figure_call} before write_report"
