"""The plots draw on their own canvas: the user's matplotlib backend and pyplot's figures are left alone."""

import sys

import matplotlib
import numpy as np

from agvctl.controllers.pi.tuning import design_pi
from agvctl.plots import render_tuning_plots, save_open_loop_plot
from agvctl.sim import simulate_open_loop, wheel_step_response

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
