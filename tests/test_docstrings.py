"""Every argument of the public API is documented: the names the API reference (docs/api.rst) lists, each with a
numpydoc ``Parameters`` section that names every parameter of its signature (python-control's meta-test)."""

from __future__ import annotations

import importlib
import inspect
import re
import warnings
from pathlib import Path
from typing import Any

import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc

API_REFERENCE = Path(__file__).resolve().parent.parent / "docs" / "api.rst"


def public_api() -> list[str]:
    """The dotted names the API reference's autosummary tables list."""
    text = API_REFERENCE.read_text(encoding="utf-8")
    return re.findall(r"^   (agvctl(?:\.\w+)+)$", text, flags=re.MULTILINE)


def resolve(dotted: str) -> Any:
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def documented_parameters(obj: Any) -> set[str]:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a malformed docstring fails here, as it would fail the docs build
        doc = ClassDoc(obj) if inspect.isclass(obj) else FunctionDoc(obj)
    return {name.strip() for p in doc["Parameters"] for name in p.name.split(",")}


def test_the_api_reference_lists_the_entry_points():
    names = public_api()
    assert len(names) == len(set(names)), "a name listed twice"
    for required in (
        "load_vehicle",
        "simulate_open_loop",
        "load_experiment",
        "run_experiment",
        "LtvMpcController",
        "PIWheelController",
        "RamseteController",
        "LtvLqrController",
        "PoseEkf",
        "check_experiments",
        "fuzz",
    ):
        assert any(n.rsplit(".", 1)[1] == required for n in names), required


@pytest.mark.parametrize("dotted", public_api())
def test_every_public_argument_is_documented(dotted):
    obj = resolve(dotted)
    parameters = [
        name
        for name, p in inspect.signature(obj).parameters.items()
        if name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
    ]
    documented = documented_parameters(obj)
    missing = [name for name in parameters if name not in documented]
    assert not missing, f"{dotted}: undocumented parameters {missing}"
    unknown = sorted(documented - set(parameters))
    assert not unknown, f"{dotted}: documented parameters not in the signature {unknown}"


@pytest.mark.parametrize("dotted", public_api())
def test_every_public_name_says_what_it_returns(dotted):
    obj = resolve(dotted)
    if inspect.isclass(obj):
        return
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        doc = FunctionDoc(obj)
    assert doc["Returns"], f"{dotted}: no Returns section"
