import os
import tempfile

import pytest

# Compiled plant code is cached per user; tests use a private cache so they never depend on an earlier run.
os.environ.setdefault("AGVCTL_CACHE_DIR", os.path.join(tempfile.gettempdir(), "agvctl-test-cache"))

from agvctl.params import VehicleParams, load_vehicle  # noqa: E402


@pytest.fixture(scope="session")
def vehicle() -> VehicleParams:
    return load_vehicle()
