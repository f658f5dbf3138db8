"""Every public function and method of the package with two or more parameters documents them
in numpydoc ``Parameters`` and ``Returns`` sections (issue 36; python-control checks the same):

* a function of a public module (no component of its dotted path starts with ``_``;
  ``__main__`` modules are skipped) whose name does not start with ``_``, compiled ones (numba
  dispatchers, their Python function) included, and every public method, static or class
  method and ``__init__`` of a public class defined there, with two or more parameters not
  counting ``self``/``cls``/``*args``/``**kwargs``;
* names each parameter in ``Parameters`` (``name : type`` lines, ``a, b : type`` allowed; the
  sphinx.ext.napoleon extension that renders docs/ reads the same), and no other name;
* has a ``Returns`` (or ``Yields``) section when its return annotation is not None (an
  unannotated function is not held to it);
* a class's ``__init__`` may be documented in the class docstring's ``Parameters`` instead (as
  numpydoc does), and a generated one (dataclass) in its ``Attributes`` too (which may also
  name properties, so its names are not held to the signature).

Only the parser of numpydoc is used (:class:`numpydoc.docscrape.FunctionDoc`); the docs are
rendered by napoleon.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from collections.abc import Callable, Iterator

from numpydoc import docscrape  # the dev extra's (pyproject.toml)

import ffsm_pin

# Offenders allowed for now, each "module.qualname"; an entry documented since fails
# test_the_allow_list_is_current, so the set only shrinks. Empty: every function is
# documented; keep it so (a new offender is documented, not listed here).
ALLOWED: frozenset[str] = frozenset()


def _public_modules() -> Iterator[str]:
    yield ffsm_pin.__name__
    for info in pkgutil.walk_packages(ffsm_pin.__path__, ffsm_pin.__name__ + "."):
        parts = info.name.split(".")[1:]
        if any(p.startswith("_") for p in parts):  # private modules and __main__
            continue
        yield info.name


def _python_function(obj: object) -> Callable | None:
    """The Python function behind obj (a function, static/class method or numba dispatcher)."""
    if isinstance(obj, (staticmethod, classmethod)):
        obj = obj.__func__
    obj = getattr(obj, "py_func", obj)  # numba's CPUDispatcher
    return obj if inspect.isfunction(obj) else None


def _checked() -> Iterator[tuple[str, Callable, type | None]]:
    """(module.qualname, function, its class or None) for every function the test holds."""
    for name in _public_modules():
        module = importlib.import_module(name)
        for attr, obj in vars(module).items():
            if attr.startswith("_"):
                continue
            if inspect.isclass(obj):
                if obj.__module__ != name:
                    continue
                yield from _methods(f"{name}.{attr}", obj)
            elif (func := _python_function(obj)) is not None and func.__module__ == name:
                yield f"{name}.{attr}", func, None


def _methods(qualname: str, cls: type) -> Iterator[tuple[str, Callable, type]]:
    """The public methods (and ``__init__``) of ``cls``, also those it takes from the
    package's private base classes (as the planar and spatial models' dynamics), each the
    one a call finds (the first in the MRO)."""
    seen: set[str] = set()
    bases = [cls, *(b for b in cls.__mro__[1:] if b.__module__.startswith("ffsm_pin."))]
    for i, klass in enumerate(bases):
        private_base = i > 0 and any(
            p.startswith("_") for p in [*klass.__module__.split(".")[1:], klass.__name__]
        )
        if i > 0 and not private_base:
            continue  # a public base is checked where it is defined
        for meth_name, meth in vars(klass).items():
            if meth_name in seen or (meth_name.startswith("_") and meth_name != "__init__"):
                continue
            seen.add(meth_name)
            if i > 0 and meth_name == "__init__":
                continue
            func = _python_function(meth)
            if func is not None:
                yield f"{qualname}.{meth_name}", func, cls


def _all_parameters(func: Callable, cls: type | None) -> list[inspect.Parameter]:
    """The parameters of func but a method's ``self``/``cls``."""
    params = list(inspect.signature(func).parameters.values())
    if cls is not None and params and params[0].name in ("self", "cls"):
        params = params[1:]
    return params


def _parameters(func: Callable, cls: type | None) -> list[str]:
    skip = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return [p.name for p in _all_parameters(func, cls) if p.kind not in skip]


def _documented(doc: object, section: str) -> set[str]:
    names = set()
    for entry in doc[section]:  # type: ignore[index]
        for name in entry.name.split(","):
            names.add(name.strip().lstrip("*"))
    return names - {""}


def _returns_nothing(func: Callable) -> bool:
    annotation = inspect.signature(func).return_annotation
    return annotation in (None, "None", inspect.Signature.empty)


def _problems(func: Callable, cls: type | None) -> list[str]:
    params = _parameters(func, cls)
    all_names = {p.name for p in _all_parameters(func, cls)}
    try:
        doc = docscrape.FunctionDoc(func)
        documented = _documented(doc, "Parameters")
        attributes: set[str] = set()  # may also name properties: not held to the signature
        if cls is not None and func.__name__ == "__init__":
            class_doc = docscrape.ClassDoc(cls, config={"show_class_members": False})
            documented |= _documented(class_doc, "Parameters")
            if func.__code__.co_filename.startswith("<"):  # generated: dataclass
                attributes = _documented(class_doc, "Attributes")
    except ValueError as exc:  # numpydoc refuses the docstring (a section twice, ...)
        return [f"unparsable: {str(exc).splitlines()[0]}"]
    problems = []
    if missing := [p for p in params if p not in documented | attributes]:
        problems.append(f"missing {', '.join(missing)}")
    if extra := sorted(documented - all_names):
        problems.append(f"extra {', '.join(extra)}")
    if func.__name__ != "__init__" and not _returns_nothing(func):
        if not doc["Returns"] and not doc["Yields"]:
            problems.append("no Returns")
    return problems


CHECKED = [(name, func, cls) for name, func, cls in _checked() if len(_parameters(func, cls)) >= 2]


def test_the_walk_finds_the_package():
    assert len(CHECKED) > 300
    names = {name for name, _, _ in CHECKED}
    assert "ffsm_pin.control.funnel.Funnel.__init__" in names  # a method
    assert "ffsm_pin.control.kernels.damped_pinv" in names  # a compiled function
    assert not any("._" in name.replace(".__init__", "") for name in names)


def test_parameters_and_returns_documented():
    offenders = {}
    for name, func, cls in CHECKED:
        if problems := _problems(func, cls):
            offenders[name] = problems
    listed = "\n".join(f"{n}: {'; '.join(p)}" for n, p in sorted(offenders.items()))
    assert set(offenders) <= ALLOWED, f"{len(set(offenders) - ALLOWED)} undocumented:\n{listed}"


def test_the_allow_list_is_current():
    """An entry that is documented now (or gone) leaves ALLOWED."""
    offenders = {name for name, func, cls in CHECKED if _problems(func, cls)}
    assert not ALLOWED - offenders, sorted(ALLOWED - offenders)
