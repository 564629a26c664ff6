"""Every argument of the public API is documented, with its unit (python-control's meta-test).

The public API is every class and function that a module of agvctl names in its ``__all__`` and defines itself: a
name a package re-exports is checked once, where it is defined. Each has a numpydoc docstring that numpydoc parses
without a warning, with a summary and a ``Parameters`` section naming exactly the parameters of its signature (a
class: its constructor's, a dataclass's fields included), each described, a dimensional one in the unit its name
carries (``radius_m``: m); a function has a ``Returns`` (or ``Yields``) section unless it returns None; the
docstring is valid reStructuredText, as the docs build needs. The examples in the package's docstrings run as
doctests.

Left out: the command line's internals, the modules under ``agvctl.cli`` other than its entry point
:func:`agvctl.cli.main`. Their contract is the commands themselves, documented by ``--help`` and the user guide and
tested through ``main(argv)``; their ``register`` and ``run(args)`` functions take an argparse namespace, whose
documentation is the parser.
"""

from __future__ import annotations

import doctest
import enum
import importlib
import inspect
import io
import pkgutil
import re
import warnings
from pathlib import Path
from types import ModuleType
from typing import Any

import docutils.core
import pytest
from docutils import nodes
from docutils.parsers.rst import roles
from numpydoc.docscrape import ClassDoc, FunctionDoc

import agvctl

API_REFERENCE = Path(__file__).resolve().parent.parent / "docs" / "api.rst"
COMMAND_LINE = "agvctl.cli"
COMMAND_LINE_ENTRY_POINT = "agvctl.cli.main"

UNITS: dict[str, tuple[str, ...]] = {
    "m": ("m",),
    "s": ("s",),
    "m_s": ("m/s",),
    "m_s2": ("m/s²",),
    "m_s3": ("m/s³",),
    "rad": ("rad",),
    "rad_s": ("rad/s",),
    "rad_s2": ("rad/s²",),
    "rad2_m2": ("rad²/m²",),
    "deg": ("°", "deg"),
    "kg": ("kg",),
    "kg_m2": ("kg m²",),
    "n_m": ("N m",),
    "n_m_a": ("N m/A",),
    "n_m_s_rad": ("N m s/rad",),
    "v": ("V",),
    "v_s": ("V/s",),
    "v_s_rad": ("V s/rad",),
    "v_rad": ("V/rad",),
    "a": ("A",),
    "ohm": ("Ω",),
    "hz": ("Hz",),
    "db": ("dB",),
    "pct": ("%",),
    "1_m": ("1/m",),
    "1_m2": ("1/m²",),
    "1_m3": ("1/m³",),
}
"""The unit a parameter's description names, by the suffix of its name (the longest suffix that matches)."""

REPORT_SYMBOLS = frozenset({"tau_s"})
"""Parameters named by the report's symbols, whose suffix is no unit (τ_s, the stiction torque)."""


def _modules() -> list[ModuleType]:
    names = [info.name for info in pkgutil.walk_packages(agvctl.__path__, "agvctl.")]
    return [agvctl, *(importlib.import_module(name) for name in sorted(names))]


def _is_command_line_internal(module: str, name: str) -> bool:
    inside = module == COMMAND_LINE or module.startswith(COMMAND_LINE + ".")
    return inside and f"{module}.{name}" != COMMAND_LINE_ENTRY_POINT


def public_definitions() -> dict[str, Any]:
    """Every public class and function by its dotted name where it is defined."""
    found: dict[str, Any] = {}
    for module in _modules():
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            defined_here = getattr(obj, "__module__", None) == module.__name__
            internal = _is_command_line_internal(module.__name__, name)
            if (inspect.isclass(obj) or inspect.isfunction(obj)) and defined_here and not internal:
                found[f"{module.__name__}.{name}"] = obj
    return found


PUBLIC = public_definitions()


def signature_parameters(obj: Any) -> list[str]:
    """What a caller passes: a class's constructor's parameters, without ``self``, ``*args`` and ``**kwargs``; none
    for an enumeration (its members, each documented, are what a caller names)."""
    if inspect.isclass(obj) and issubclass(obj, enum.Enum):
        return []
    try:
        signature = inspect.signature(obj)
    except ValueError:  # a class whose constructor is a builtin one, e.g. a Warning's: nothing of its own
        return []
    skipped = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return [name for name, p in signature.parameters.items() if name != "self" and p.kind not in skipped]


def unit_of(name: str) -> tuple[str, ...]:
    """The units a parameter's description may name for the suffix of ``name`` (none for a dimensionless one)."""
    if name in REPORT_SYMBOLS:
        return ()
    for suffix in sorted(UNITS, key=len, reverse=True):
        if name.endswith("_" + suffix):
            return UNITS[suffix]
    return ()


def names_unit(text: str, units: tuple[str, ...]) -> bool:
    return any(re.search(rf"(?<![\w/]){re.escape(u)}(?![\w/²³])", text) for u in units)


def _literal_role(name: str, rawtext: str, text: str, *args: Any, **kwargs: Any) -> tuple[list[nodes.Node], list[Any]]:
    return [nodes.literal(rawtext, text)], []


for _role in ("func", "class", "meth", "attr", "data", "mod", "exc", "obj", "ref", "doc", "math", "term"):
    roles.register_local_role(_role, _literal_role)  # Sphinx's cross-references, as plain docutils sees them


def rst_problems(text: str) -> list[str]:
    """What docutils finds wrong in a docstring as reStructuredText: an ``|x|`` outside a literal is a substitution,
    a word ending in ``_`` a link, and the docs build fails on either."""
    stream = io.StringIO()
    overrides = {"report_level": 2, "halt_level": 5, "warning_stream": stream}
    docutils.core.publish_doctree(text, settings_overrides=overrides)
    return [line for line in stream.getvalue().splitlines() if re.search(r"\((WARNING|ERROR|SEVERE)/", line)]


def parse(obj: Any) -> ClassDoc | FunctionDoc:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a malformed docstring fails here, as it would fail the docs build
        return ClassDoc(obj) if inspect.isclass(obj) else FunctionDoc(obj)


def docstring_problems(dotted: str, obj: Any) -> list[str]:
    """What is wrong with the docstring of ``obj``, one line each (none: it is complete)."""
    try:
        doc = parse(obj)
    except Exception as exc:
        return [f"numpydoc cannot parse it: {exc}"]
    problems = [] if doc["Summary"] else ["no summary"]
    problems += [f"not valid reStructuredText: {line}" for line in rst_problems(inspect.getdoc(obj) or "")]
    parameters = signature_parameters(obj)
    entries = {name.strip(): p for p in doc["Parameters"] for name in p.name.split(",")}
    missing = [name for name in parameters if name not in entries]
    unknown = sorted(set(entries) - set(parameters))
    if missing:
        problems.append(f"undocumented parameters {missing}")
    if unknown:
        problems.append(f"documented parameters not in the signature {unknown}")
    for name, entry in entries.items():
        text = " ".join(entry.desc)
        if not text.strip():
            problems.append(f"{name}: no description")
        elif unit_of(name) and not names_unit(text, unit_of(name)):
            problems.append(f"{name}: its description does not name its unit {' or '.join(unit_of(name))}")
    if not inspect.isclass(obj):
        returns_none = inspect.signature(obj).return_annotation in (None, "None")
        if not returns_none and not (doc["Returns"] or doc["Yields"]):
            problems.append("no Returns section")
    return problems


@pytest.mark.parametrize("dotted", sorted(PUBLIC))
def test_every_public_definition_is_documented(dotted):
    problems = docstring_problems(dotted, PUBLIC[dotted])
    assert not problems, f"{dotted}: " + "; ".join(problems)


def test_the_public_api_is_the_whole_package():
    assert len(PUBLIC) > 350
    for module in _modules():
        if not module.__name__.startswith(COMMAND_LINE + "."):
            assert hasattr(module, "__all__"), f"{module.__name__} does not declare its public names"
    assert COMMAND_LINE_ENTRY_POINT in PUBLIC
    assert not any(name.startswith(COMMAND_LINE + ".") and name != COMMAND_LINE_ENTRY_POINT for name in PUBLIC)


def api_reference() -> list[str]:
    """The dotted names the API reference's autosummary tables list."""
    text = API_REFERENCE.read_text(encoding="utf-8")
    return re.findall(r"^   (agvctl(?:\.\w+)+)$", text, flags=re.MULTILINE)


def test_the_api_reference_lists_public_definitions_and_the_entry_points():
    names = api_reference()
    assert len(names) == len(set(names)), "a name listed twice"
    public = {id(obj) for obj in PUBLIC.values()}
    for dotted in names:
        module, _, name = dotted.rpartition(".")
        assert id(getattr(importlib.import_module(module), name)) in public, f"{dotted} is not public"
    for required in (
        "load_vehicle",
        "simulate_open_loop",
        "load_experiment",
        "run_experiment",
        "run_closed_loop",
        "LtvMpcController",
        "PIWheelController",
        "TuningSpec",
        "RamseteController",
        "LtvLqrController",
        "PoseEkf",
        "check_experiments",
        "fuzz",
        "umbmark_correction",
        "fit_friction",
        "identify_mass",
    ):
        assert any(n.rsplit(".", 1)[1] == required for n in names), required


def _modules_with_examples() -> list[str]:
    finder = doctest.DocTestFinder()
    return [m.__name__ for m in _modules() if any(t.examples for t in finder.find(m))]


@pytest.mark.parametrize("module", _modules_with_examples())
def test_the_examples_in_docstrings_run(module):
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
    runner = doctest.DocTestRunner(optionflags=flags)
    for test in doctest.DocTestFinder().find(importlib.import_module(module)):
        runner.run(test)
    assert runner.failures == 0, f"{module}: {runner.failures} of {runner.tries} examples failed (see above)"
