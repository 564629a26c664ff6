"""The plots draw on their own canvas: the user's matplotlib backend and pyplot's figures are left alone; the run
panel kept between runs draws what a new figure draws."""

import sys
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import matplotlib
import numpy as np
import pytest

from agvctl.controllers.pi.tuning import design_pi
from agvctl.log import SimLog
from agvctl.plots import render_run_panel, render_tuning_plots, save_metric_histograms, save_open_loop_plot
from agvctl.scenario.experiment import load_experiment, run_experiment
from agvctl.sim import simulate_open_loop, wheel_step_response

ROOT = Path(__file__).resolve().parents[1]

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_plots_leave_the_users_matplotlib_backend_alone(vehicle, tmp_path):
    previous = matplotlib.get_backend()
    matplotlib.use("svg")  # a backend the user chose, not Agg
    try:
        da = np.repeat(np.array([[2.0, 3.0], [-1.0, 4.0]]), 25, axis=0)
        path = save_open_loop_plot(simulate_open_loop(vehicle, da).log, vehicle, tmp_path / "open_loop.png")
        design = design_pi(vehicle)
        step = wheel_step_response(vehicle, design.gains, wheel_speed_step_m_s=0.1)
        figures = render_tuning_plots(design, step, vehicle, 0.1)
        assert matplotlib.get_backend() == "svg"
    finally:
        matplotlib.use(previous)
    assert path.read_bytes().startswith(PNG_SIGNATURE)
    assert sorted(figures) == ["bode.png", "nyquist.png", "step.png"]
    assert all(png.startswith(PNG_SIGNATURE) for png in figures.values())
    if "matplotlib.pyplot" in sys.modules:  # no figure left open in pyplot's global state
        assert sys.modules["matplotlib.pyplot"].get_fignums() == []


@pytest.fixture(scope="module")
def two_panels(vehicle) -> Callable[[int], bytes]:
    """``draw(i)``: the run panel of one of two runs of ``line.toml``, the second with other lines and bounds."""
    log = run_experiment(load_experiment(ROOT / "experiments" / "line.toml")).log
    worse = {k: log[k] * 10 for k in ("cross_track_error_m", "position_error_m", "current_left_a")}
    apart = SimLog({**log.columns, **worse, "est_x_m": log["est_x_m"] + 0.01})
    # first a bound under a millimetre on the log axis, a current bound of its own and a mark; then larger errors, an
    # estimate off the truth and a bound just above the errors (on the log axis, or the linear one a new axes starts
    # with, a bound line widens the limits or not)
    runs = [
        (
            log,
            {"tracking_error_max_m": 1e-6, "peak_motor_current_a": 5.5},
            1.5,
            "tracking_error_max_m: worst at t = 1.50 s",
        ),
        (apart, {"tracking_error_max_m": 1.2 * float(np.max(apart["position_error_m"]))}, None, ""),
    ]

    def draw(i: int) -> bytes:
        run_log, bounds, mark_time_s, mark_label = runs[i]
        return render_run_panel(
            run_log, vehicle, title=f"run {i}", bounds=bounds, mark_time_s=mark_time_s, mark_label=mark_label
        )

    return draw


def _on_new_figures(draw: Callable[[int], bytes]) -> list[bytes]:
    """Each of the two panels drawn in a thread of its own: on a new figure."""
    new = []
    for i in range(2):
        with ThreadPoolExecutor(max_workers=1) as thread:
            new.append(thread.submit(draw, i).result())
    assert new[0] != new[1]
    return new


def test_a_run_panel_on_the_figure_kept_from_other_runs_is_the_png_of_a_new_figure(two_panels):
    new = _on_new_figures(two_panels)
    assert [two_panels(i) for i in (0, 1, 0, 1)] == new * 2  # this thread's figure, kept from run to run


def test_a_run_panel_after_a_change_of_style_is_drawn_in_the_new_style(two_panels):
    two_panels(0)  # this thread's figure, made in the present style
    with matplotlib.rc_context({"axes.facecolor": "#e5e5e5", "axes.grid": False}):
        restyled = _on_new_figures(two_panels)
        assert [two_panels(0), two_panels(1)] == restyled
    assert two_panels(0) != restyled[0]


def test_run_panels_drawn_in_threads_at_once_are_those_drawn_one_by_one_and_leave_rcparams_alone(two_panels):
    new = _on_new_figures(two_panels)
    hinting = matplotlib.rcParams["text.hinting"]
    with ThreadPoolExecutor(max_workers=4) as threads:
        drawn = list(threads.map(two_panels, [0, 1] * 6))
    assert drawn == new * 6
    assert matplotlib.rcParams["text.hinting"] == hinting


def test_a_metric_histogram_shows_its_bars_beside_a_distant_bound(tmp_path):
    from PIL import Image

    from agvctl.checks.report import CheckReport, ExperimentReport, LimitVerdict, RunOutcome, RunTask

    # four samples within 0.3 mm of one another and a bound five times their value: bins over the samples alone
    # would be a third of a pixel wide
    values = [0.0200, 0.0201, 0.0202, 0.0203]
    outcomes = [RunOutcome(RunTask("e.toml", k), {"cross_track_error_max_m": v}, (), 0.0) for k, v in enumerate(values)]
    verdict = LimitVerdict("cross_track_error_max_m", 0.1, True, 0.0203, None, None, 3, {}, 4, 0)
    report = CheckReport(experiments=[ExperimentReport("e", "e.toml", [verdict], outcomes, 0.0)])
    (path,) = save_metric_histograms(report, tmp_path)
    assert path.name == "e_cross_track_error_max_m.png" and path.read_bytes().startswith(PNG_SIGNATURE)
    rgb = np.asarray(Image.open(path).convert("RGB")).astype(int)
    blue = np.abs(rgb - np.array([0x1F, 0x77, 0xB4])).sum(axis=2) < 30  # matplotlib's first colour, the bars
    assert blue.sum() > 0.02 * blue.size
