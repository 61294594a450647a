"""Test configuration: one deterministic Hypothesis profile for the whole suite."""
from hypothesis import HealthCheck, settings

settings.register_profile(
    "sweep",
    deadline=None,
    max_examples=60,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
settings.load_profile("sweep")


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Lines tests leave for the summary (the fuzz campaign's count of cases)."""
    for line in getattr(config, "sweep_summary_lines", []):
        terminalreporter.write_line(line)
