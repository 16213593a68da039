"""config/safety_filter.yaml and the node's defaults agree, and the file loads as parameters."""

from dataclasses import asdict

from safe_legged_c3bf.run.config import config_path, load_yaml
from safe_legged_c3bf.safety.params import FilterParams


def test_yaml_equals_defaults():
    values = load_yaml(config_path("safety_filter.yaml"))["safety_filter"]["ros__parameters"]
    defaults = asdict(FilterParams())
    defaults["weights"] = list(defaults["weights"])
    assert values == defaults
    FilterParams(**{**values, "weights": tuple(values["weights"])}).validate()
