"""The long profiles draw the same cases on every run; SWEEP_EXPLORE draws fresh ones
(tests/profiles.py). Checked on the settings each long profile builds, in a fresh interpreter
per environment (the switches are read at import)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).parent
LONG = {"SWEEP_LONG_PROPERTIES": "1", "SWEEP_LONG_FUZZ": "1"}
#: What each Hypothesis profile of the long run is, as Python that prints its `derandomize`
PROBE = """
import sys
sys.path.insert(0, {tests!r})
import conftest, test_accepted_space, test_stability, test_fuzz
from hypothesis import settings
print(settings.default.derandomize, test_accepted_space.PROFILE.derandomize,
      test_stability.PROFILE.derandomize, test_fuzz.profile("paths").derandomize,
      test_accepted_space.EXAMPLES, test_fuzz.LONG)
"""


def probe(extra: dict) -> list[str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("SWEEP_")}
    env.update(LONG, **extra)
    out = subprocess.run([sys.executable, "-c", PROBE.format(tests=str(TESTS))], env=env,
                         capture_output=True, text=True, check=True)
    return out.stdout.split()


@pytest.mark.parametrize("explore", ["", "0", "1"])
def test_the_long_profiles_draw_fixed_cases_unless_exploring(explore):
    fields = probe({"SWEEP_EXPLORE": explore})
    derandomized, long_examples, long_fuzz = fields[:4], int(fields[4]), fields[5]
    assert long_examples > 100 and long_fuzz == "True"   # the long counts are on
    assert derandomized == (["False"] * 4 if explore == "1" else ["True"] * 4)
