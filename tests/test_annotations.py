"""Every public function, public class's own `__init__` and public method that introduces a
name annotates its arguments (jaxtyping on public signatures, docs/testing.md): the
annotations are what the suite's jaxtyping hook checks, what a notebook's `?` shows and what
the API pages print.

Public means reachable without an underscore: a name without one in a module whose dotted
path has none (`jaxatt.scenarios.wu2018.initial_state`, `jaxatt.safety.KeepOutSphere`, the
latter defined in `jaxatt.safety._sets`). A public class's methods (and `__call__`) are
audited where they introduce a name; an override takes the annotations of the method it
overrides, which states the contract once (`AbstractController.__call__`,
`AbstractMetric.stream_update`, `AbstractTransform.forward`).
"""

import importlib
import inspect
import pkgutil

import jaxatt


def _public_modules():
    yield jaxatt
    for info in pkgutil.walk_packages(jaxatt.__path__, "jaxatt."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        yield importlib.import_module(info.name)


def _unannotated(function, *, skip_first: bool, need_return: bool) -> list[str]:
    signature = inspect.signature(function)
    parameters = list(signature.parameters.values())[1 if skip_first else 0 :]
    missing = [
        p.name
        for p in parameters
        if p.annotation is inspect.Parameter.empty
        and p.kind not in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    ]
    if need_return and signature.return_annotation is inspect.Signature.empty:
        missing.append("return")
    return missing


def _gaps() -> dict[str, list[str]]:
    gaps = {}
    for module in _public_modules():
        for name, obj in vars(module).items():
            if name.startswith("_") or not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            if not obj.__module__.startswith("jaxatt"):
                continue
            where = f"{obj.__module__}.{obj.__qualname__}"
            if inspect.isfunction(obj):
                missing = _unannotated(obj, skip_first=False, need_return=True)
            elif inspect.isclass(obj):
                gaps.update(_class_gaps(obj, where))
                continue
            else:
                continue
            if missing:
                gaps[where] = missing
    return gaps


def _class_gaps(cls: type, where: str) -> dict[str, list[str]]:
    gaps = {}
    for name, function in vars(cls).items():
        if not inspect.isfunction(function) and not isinstance(function, staticmethod):
            continue
        if name == "__init__":
            missing = _unannotated(function, skip_first=True, need_return=False)
        elif name.startswith("_") and name != "__call__":
            continue
        elif any(name in vars(base) for base in cls.__mro__[1:]):
            continue  # an override: the base method states the contract
        elif isinstance(function, staticmethod):
            missing = _unannotated(function.__func__, skip_first=False, need_return=True)
        else:
            missing = _unannotated(function, skip_first=True, need_return=True)
        if missing:
            gaps[f"{where}.{name}"] = missing
    return gaps


def test_public_functions_constructors_and_methods_annotate_their_arguments():
    assert _gaps() == {}


def test_the_audit_sees_an_unannotated_function(monkeypatch):
    import jaxatt.scenarios.zhang2017 as module

    def first_zero_times(ts, s, band: float = 0.0):  # the signature before the annotations
        return ts

    first_zero_times.__module__ = module.__name__
    first_zero_times.__qualname__ = "first_zero_times"
    monkeypatch.setattr(module, "first_zero_times", first_zero_times)
    assert _gaps() == {"jaxatt.scenarios.zhang2017.first_zero_times": ["ts", "s", "return"]}


def test_the_audit_sees_an_unannotated_method_but_not_an_override(monkeypatch):
    import jaxatt.safety as module

    class Planted(module.ConeCorridor):
        def profile(self, x):  # an override: ConeCorridor.profile states the contract
            return x

        def width(self, x):  # a name of its own
            return x

    Planted.__module__, Planted.__qualname__ = module.ConeCorridor.__module__, "Planted"
    monkeypatch.setattr(module, "Planted", Planted, raising=False)
    assert _gaps() == {"jaxatt.safety._sets.Planted.width": ["x", "return"]}
