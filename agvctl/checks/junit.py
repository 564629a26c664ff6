"""JUnit XML for ``agvctl check``: one test suite per experiment, one test case per limit."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from agvctl.checks.report import CheckReport

__all__ = ["junit_xml"]


def junit_xml(report: CheckReport) -> str:
    """The report as JUnit XML (the schema CI systems read: testsuites/testsuite/testcase/failure).

    Dashboards count from the ``tests``, ``failures``, ``errors`` and ``skipped`` attributes of ``<testsuites>`` and
    each ``<testsuite>``; a violated limit is a ``<failure>`` whose ``message`` is the limit message.
    """
    root = ET.Element("testsuites", name="agvctl check")
    total = failures = 0
    for exp in report.experiments:
        suite = ET.SubElement(root, "testsuite", name=exp.name, file=exp.path)
        n_fail = 0
        for v in exp.verdicts:
            case = ET.SubElement(
                suite,
                "testcase",
                classname=f"agvctl.check.{exp.name}",
                name=v.limit,
                time=f"{exp.wall_time_s / max(1, len(exp.verdicts)):.3f}",
            )
            if not v.passed:
                n_fail += 1
                fail = ET.SubElement(case, "failure", message=v.message, type="LimitViolated")
                fail.text = v.message
            else:
                ET.SubElement(case, "system-out").text = v.message
        suite.set("tests", str(len(exp.verdicts)))
        suite.set("failures", str(n_fail))
        suite.set("errors", "0")
        suite.set("skipped", "0")
        suite.set("time", f"{exp.wall_time_s:.3f}")
        total += len(exp.verdicts)
        failures += n_fail
    root.set("tests", str(total))
    root.set("failures", str(failures))
    root.set("errors", "0")
    root.set("skipped", "0")
    root.set("time", f"{report.wall_time_s:.3f}")
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
