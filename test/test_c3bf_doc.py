"""The example in doc/c3bf_api.md runs and is ten lines."""

import re
from pathlib import Path

from safe_legged_c3bf.c3bf import FilterStatus

DOC = Path(__file__).resolve().parents[1] / "doc" / "c3bf_api.md"


def test_api_doc_example_runs(capsys):
    text = DOC.read_text()
    code = re.search(r"## Example: filter one command\n\n```python\n(.*?)```", text, re.S)
    assert code is not None
    lines = code.group(1).strip().splitlines()
    assert len(lines) <= 10
    scope: dict = {}
    exec(compile(code.group(1), str(DOC), "exec"), scope)
    res = scope["res"]
    assert res.status in (FilterStatus.ACTIVE, FilterStatus.INACTIVE)
    assert "active" in capsys.readouterr().out


def test_public_api_exports():
    import safe_legged_c3bf.c3bf as c3bf

    for name in c3bf.__all__:
        assert hasattr(c3bf, name)
