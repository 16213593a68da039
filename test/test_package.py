"""The installed package: imports from anywhere, finds its config, matches its contract."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.run import config

REPO = Path(__file__).resolve().parent.parent


def test_imports_and_config_from_any_working_directory(tmp_path):
    code = (
        "import safe_legged_c3bf, safe_legged_c3bf_msgs.msg as m; "
        "from safe_legged_c3bf.run.config import config_dir; "
        "d = config_dir(); print(d); "
        "assert (d / 'safety_filter.yaml').is_file(); "
        "assert any((d / 'scenarios').glob('*.yaml')); "
        "assert m.Obstacle and m.SafetyFilterState"
    )
    env = {k: v for k, v in os.environ.items() if k != "SAFE_LEGGED_C3BF_CONFIG"}
    env.pop("PYTHONPATH", None)
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr


def test_config_found_in_installed_layout(tmp_path, monkeypatch):
    # A regular (non-editable) install puts config/ under <prefix>/share/safe_legged_c3bf.
    share = tmp_path / "share" / "safe_legged_c3bf" / "config"
    share.mkdir(parents=True)
    (share / "safety_filter.yaml").write_text("{}\n")
    monkeypatch.setattr(sys, "prefix", str(tmp_path))
    monkeypatch.delenv("SAFE_LEGGED_C3BF_CONFIG", raising=False)
    monkeypatch.setattr(config, "__file__", str(tmp_path / "site-packages" / "x" / "config.py"))
    assert config.config_dir() == share


def test_config_env_override(tmp_path, monkeypatch):
    (tmp_path / "safety_filter.yaml").write_text("{}\n")
    monkeypatch.setenv("SAFE_LEGGED_C3BF_CONFIG", str(tmp_path))
    assert config.config_dir() == tmp_path


def test_missing_config_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "prefix", str(tmp_path))
    monkeypatch.delenv("SAFE_LEGGED_C3BF_CONFIG", raising=False)
    monkeypatch.setattr(config, "__file__", str(tmp_path / "a" / "b" / "config.py"))
    monkeypatch.setattr(config, "_candidates", lambda: [tmp_path / "nowhere"])
    with pytest.raises(FileNotFoundError, match="config directory not found"):
        config.config_dir()


def test_readme_embeds_the_topic_contract():
    readme = (REPO / "README.md").read_text()
    assert topics.markdown_table() in readme, "README topic table differs from topics.py"


def test_contract_types_import():
    for topic in topics.CONTRACT:
        assert topic.msg_class() is not None
        assert topic.name.startswith("/")
    assert len({t.name for t in topics.CONTRACT}) == len(topics.CONTRACT)


def test_every_console_script_has_a_main():
    setup_py = (REPO / "setup.py").read_text()
    modules = re.findall(r'"(\w+)": "(\w+_node)"', setup_py)
    assert len(modules) >= 5
    for _, module in modules:
        mod = importlib.import_module(f"safe_legged_c3bf.nodes.{module}")
        assert callable(mod.main)
    for module in ("bringup", "echo", "evaluate"):
        assert callable(importlib.import_module(f"safe_legged_c3bf.{module}").main)


def test_package_xml_is_format_3_with_real_dependencies():
    xml = (REPO / "package.xml").read_text()
    assert '<package format="3">' in xml
    for dep in ("rclpy", "geometry_msgs", "nav_msgs", "safe_legged_c3bf_msgs", "python3-numpy"):
        assert f"<exec_depend>{dep}</exec_depend>" in xml
    assert (REPO / "resource" / "safe_legged_c3bf").is_file()


def test_ruff_is_clean():
    ruff = Path(sys.executable).with_name("ruff")
    exe = [str(ruff)] if ruff.exists() else [sys.executable, "-m", "ruff"]
    out = subprocess.run(
        [*exe, "check", "safe_legged_c3bf", "test", "benchmarks"],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stdout + out.stderr


def test_readme_library_example_runs(capsys):
    readme = (REPO / "README.md").read_text()
    code = readme.split("```python", 1)[1].split("```", 1)[0]
    exec(compile(code, "README.md", "exec"), {})  # noqa: S102 - our own documentation
    status = capsys.readouterr().out.split()[0]
    assert status in {"inactive", "active", "relaxed"}
