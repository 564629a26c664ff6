"""JUnit XML for ``agvctl check`` (one test suite per experiment, one test case per limit) and ``agvctl fuzz``
(one test suite per pose controller, one test case per scenario)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

from agvctl.checks.report import CheckReport
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


def junit_xml(report: CheckReport) -> str:
    """A check report as JUnit XML: one test suite per experiment, one test case per limit.

    Parameters
    ----------
    report : CheckReport
        The report of :func:`~agvctl.checks.runner.check_experiments`.

    Returns
    -------
    str
        The XML document: a violated limit is a ``<failure>`` whose ``message`` is the limit message; a run that
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
            )
            for v in exp.verdicts
        ]
        suites.append(JUnitSuite(exp.name, exp.path, cases, exp.wall_time_s))
    return junit_suites("agvctl check", suites, report.wall_time_s)
