"""One self-contained HTML page a person reads for a check or a fuzz run: every verdict beside its plots.

The page holds everything it shows — the figures as embedded PNG, the resolved experiment files as text — so it
opens from a CI artifact with no network and no JavaScript. It is rendered from Jinja2 templates shipped with the
package, the figures drawn with matplotlib (:func:`~agvctl.plots.render_run_panel`)::

    report = check_experiments(paths, render=check_run_figures)  # each run's figure drawn where it runs
    write_check_html(report, "report.html")

A report made without ``render`` gets its figures by running each shown run again, in this process.

The page of a falsification search (``falsify.html.j2``) is filled in by :mod:`agvctl.falsify.page`, above this
package in the block diagram, with the same templates, embedding and writing.
"""

from agvctl.htmlreport.check_page import check_html, write_check_html
from agvctl.htmlreport.figures import check_run_figures
from agvctl.htmlreport.fuzz_page import fuzz_html, write_fuzz_html

__all__ = ["check_html", "check_run_figures", "fuzz_html", "write_check_html", "write_fuzz_html"]
