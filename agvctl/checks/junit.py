"""JUnit XML for ``agvctl check`` (one test suite per experiment, one test case per limit) and ``agvctl fuzz``
(one test suite per pose controller, one test case per scenario)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

from agvctl.checks.report import CheckReport, LimitVerdict
from agvctl.config import document_fields

__all__ = ["JUnitCase", "JUnitSuite", "junit_suites", "junit_xml"]


@document_fields
@dataclass(frozen=True)
class JUnitCase:
    """One test case: passed (``output`` only), failed (``failure``) or broken (``error``, e.g. a crash)."""

    classname: str
    """Its class name, as CI dashboards group cases (``agvctl.check.<experiment>``)."""
    name: str
    """Its name (the limit, or ``run``)."""
    time_s: float
    """Its share of the wall time, s."""
    output: str = ""
    """What it printed (a passed limit's message)."""
    failure: str | None = None
    """Why it failed (a violated limit's message); None if it did not."""
    error: str | None = None
    """Why it broke (a run that raised); None if it did not."""
    properties: tuple[tuple[str, str], ...] = ()
    """``<properties>`` of the case, (name, value) pairs: a verdict's margin, its time and window."""


@document_fields
@dataclass(frozen=True)
class JUnitSuite:
    """One test suite: an experiment of ``check``, or a pose controller of ``fuzz``."""

    name: str
    """Its name."""
    file: str
    """The file it comes from."""
    cases: Sequence[JUnitCase]
    """Its test cases."""
    time_s: float
    """Its wall time, s."""


def junit_suites(name: str, suites: Sequence[JUnitSuite], time_s: float) -> str:
    """JUnit XML of test suites, in the schema CI systems read: testsuites/testsuite/testcase/failure|error.

    Dashboards count from the ``tests``, ``failures``, ``errors`` and ``skipped`` attributes of ``<testsuites>`` and
    each ``<testsuite>``; a failure's or error's ``message`` is its text.

    Parameters
    ----------
    name : str
        The name of ``<testsuites>`` (``agvctl check``).
    suites : sequence of JUnitSuite
        The suites.
    time_s : float
        The whole run's wall time, s.

    Returns
    -------
    str
        The XML document.
    """
    root = ET.Element("testsuites", name=name)
    totals = {"tests": 0, "failures": 0, "errors": 0}
    for s in suites:
        suite = ET.SubElement(root, "testsuite", name=s.name, file=s.file)
        counts = {"tests": len(s.cases), "failures": 0, "errors": 0}
        for c in s.cases:
            case = ET.SubElement(suite, "testcase", classname=c.classname, name=c.name, time=f"{c.time_s:.3f}")
            if c.properties:
                props = ET.SubElement(case, "properties")
                for prop, text in c.properties:
                    ET.SubElement(props, "property", name=prop, value=text)
            if c.error is not None:
                counts["errors"] += 1
                ET.SubElement(case, "error", message=c.error, type="Crash").text = c.error
            elif c.failure is not None:
                counts["failures"] += 1
                ET.SubElement(case, "failure", message=c.failure, type="LimitViolated").text = c.failure
            if c.output:
                ET.SubElement(case, "system-out").text = c.output
        for key, value in counts.items():
            suite.set(key, str(value))
            totals[key] += value
        suite.set("skipped", "0")
        suite.set("time", f"{s.time_s:.3f}")
    for key, value in totals.items():
        root.set(key, str(value))
    root.set("skipped", "0")
    root.set("time", f"{time_s:.3f}")
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _margin_properties(v: LimitVerdict) -> tuple[tuple[str, str], ...]:
    """A verdict's margin, normalised margin, worst time and window as JUnit properties (``nan`` where missing)."""
    window = v.window_s if v.window_s is not None else (math.nan, math.nan)
    worst = v.worst_time_s if v.worst_time_s is not None else math.nan
    return (
        ("kind", v.kind),
        ("margin", f"{v.margin:.6g}"),
        ("unit", v.unit.strip()),
        ("normalised_margin", f"{v.normalised_margin:.6g}"),
        ("worst_time_s", f"{worst:.6g}"),
        ("window_start_s", f"{window[0]:.6g}"),
        ("window_end_s", f"{window[1]:.6g}"),
    )


def junit_xml(report: CheckReport) -> str:
    """A check report as JUnit XML: one test suite per experiment, one test case per limit.

    Parameters
    ----------
    report : CheckReport
        The report of :func:`~agvctl.checks.runner.check_experiments`.

    Returns
    -------
    str
        The XML document: a violated limit or broken requirement is a ``<failure>`` whose ``message`` is its
        message (with its margin); every verdict's case has ``<properties>`` ``kind``, ``margin``, ``unit``,
        ``normalised_margin``, ``worst_time_s``, ``window_start_s`` and ``window_end_s``; a run that
        could not be completed is a test case of its own, ``run`` (``run (sample i)`` for a Monte Carlo sample),
        with an ``<error>`` whose ``message`` is the run's error.
    """
    suites = []
    for exp in report.experiments:
        each = exp.wall_time_s / max(1, len(exp.verdicts) + len(exp.errors))
        cases = [
            JUnitCase(
                f"agvctl.check.{exp.name}",
                "run" if o.task.sample is None else f"run (sample {o.task.sample})",
                each,
                error=o.error,
            )
            for o in exp.errors
        ]
        cases += [
            JUnitCase(
                f"agvctl.check.{exp.name}",
                v.limit,
                each,
                output="" if not v.passed else v.message,
                failure=None if v.passed else v.message,
                properties=_margin_properties(v),
            )
            for v in exp.verdicts
        ]
        suites.append(JUnitSuite(exp.name, exp.path, cases, exp.wall_time_s))
    return junit_suites("agvctl check", suites, report.wall_time_s)
