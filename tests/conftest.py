import os
import tempfile

import pytest
from hypothesis import settings

# Property tests draw their examples deterministically: the same examples on every run and machine.
settings.register_profile("agvctl", derandomize=True, deadline=None)
settings.load_profile("agvctl")

# Compiled plant code is cached per user; tests use a private cache so they never depend on an earlier run.
os.environ.setdefault("AGVCTL_CACHE_DIR", os.path.join(tempfile.gettempdir(), "agvctl-test-cache"))

from html_pages import pages  # noqa: E402, F401  (the pages of check --html and fuzz --html, built once)

from agvctl.params import VehicleParams, load_vehicle  # noqa: E402


@pytest.fixture(scope="session")
def vehicle() -> VehicleParams:
    return load_vehicle()
