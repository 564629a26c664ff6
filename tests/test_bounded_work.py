"""Every size a user gives is bounded before anything is allocated for it, with one line naming the key and the
bound: samples per run (at most 10^7), RK4 substeps per sample (at most 4096), the MPC horizon (at most 500), the
segments of a path (at most 10 000), the UMBmark square (at most 100 m) and its runs (at most 100)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_runs import one_line, run

from agvctl.calibration.umbmark.experiment import UmbmarkConfig
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.errors import ConfigError
from agvctl.params import load_vehicle
from agvctl.planning import LineSegment, WheelLimits, plan_segments
from agvctl.planning.arguments import MAX_REFERENCE_SAMPLES
from agvctl.planning.spec import MAX_SEGMENTS, PathSpec

ROOT = Path(__file__).resolve().parent.parent
LIMITS = WheelLimits(0.8, 0.5, 3.0)


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            [
                "simulate",
                "--duration",
                "1",
                "--da-left",
                "1",
                "--da-right",
                "1",
                "--set",
                "control.sample_period_s=1e-9",
            ],
            "control.sample_period_s: must be >= 0.0001 (got 1e-09)",
        ),
        (
            [
                "simulate",
                "--duration",
                "14000",
                "--da-left",
                "1",
                "--da-right",
                "1",
                "--set",
                "control.sample_period_s=0.001",
            ],
            "agvctl: --duration: 14000 s at control.sample_period_s = 0.001 s would take 1.4e+07 samples, above the "
            "maximum 10000000 per run",
        ),
        (
            [
                "simulate",
                "--duration",
                "0.1",
                "--da-left",
                "1",
                "--da-right",
                "1",
                "--set",
                "friction_model.p_factor=1e12",
            ],
            "friction_model.p_factor: the plant would need 6.11e+11 RK4 substeps per control sample, above the "
            "maximum 4096",
        ),
        (
            ["identify", "umbmark", "--simulate", "--side-m", "1e6"],
            "agvctl: --side-m: must be > 0 and <= 100 m (got 1e+06)",
        ),
        (
            ["identify", "umbmark", "--simulate", "--runs", "1000000"],
            "agvctl: --runs: must be >= 1 and <= 100 (got 1000000)",
        ),
    ],  # fmt: skip
    ids=["sample period", "samples", "substeps", "umbmark side", "umbmark runs"],
)
def test_a_size_beyond_its_bound_is_one_line_naming_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], line: str
) -> None:
    out = tmp_path / "out.csv" if argv[0] == "simulate" else tmp_path / "v.toml"
    code, printed, err = run(capsys, *argv, "--out", out)
    assert code == 2 and printed == ""
    one_line(err, line)
    assert list(tmp_path.iterdir()) == []


def test_an_mpc_horizon_beyond_500_is_refused_in_the_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copy(ROOT / "trajectories" / "line.toml", tmp_path / "line.toml")
    exp = tmp_path / "h.toml"
    exp.write_text('name = "h"\ntrajectory = "line.toml"\n[controller]\nhorizon = 1000000\n')
    code, _, err = run(capsys, "run", exp, "--out", tmp_path / "out")
    assert code == 2
    one_line(err, f"agvctl: {exp}: controller.horizon: must be <= 500 (got 1e+06)")
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match="MpcConfig: horizon: must be <= 500"):
        MpcConfig(horizon=501)


def test_a_path_of_more_than_ten_thousand_segments_is_refused_before_it_is_built(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "many.toml"
    path.write_text('[[segments]]\ntype = "line"\nlength_m = 0.01\n' * (MAX_SEGMENTS + 1))
    code, _, err = run(capsys, "plan", path, "--out", tmp_path / "ref.csv")
    assert code == 2
    one_line(err, f"agvctl: {path}: segments: at most 10000 (got 10001)")
    segments = (LineSegment(length_m=0.01),) * (MAX_SEGMENTS + 1)
    with pytest.raises(ConfigError, match="plan_segments: segments: give 1 … 10000 segments"):
        plan_segments(segments, limits=LIMITS, separation_m=0.5, sample_period_s=0.04)
    with pytest.raises(ConfigError, match="segments: at most 10000"):
        PathSpec(segments=segments)


def test_a_reference_of_more_than_a_million_samples_is_refused_naming_the_segment() -> None:
    long_line = (LineSegment(length_m=5e3),) * 4  # 5 km at 0.8 m/s take 6250 s, 3.1e6 samples of 2 ms
    with pytest.raises(
        ConfigError, match=f"plan_segments: segments\\[0\\].length_m: .* above the {MAX_REFERENCE_SAMPLES} "
    ):
        plan_segments(long_line, limits=LIMITS, separation_m=0.5, sample_period_s=0.002)


def test_the_vehicle_api_refuses_the_same_sizes_as_the_file() -> None:
    with pytest.raises(ConfigError, match="control.sample_period_s: must be >= 0.0001"):
        load_vehicle(None, ["control.sample_period_s=1e-9"])
    with pytest.raises(ConfigError, match="UmbmarkConfig: side_length_m: must be <= 100 m"):
        UmbmarkConfig(side_length_m=1e6)
