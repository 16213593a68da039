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


def _documented_defaults():
    """``(name, parameter, documented value)`` for every ``key=literal`` in a signature of
    the API doc (the example section, which passes non-default values, is left out)."""
    import ast

    text = DOC.read_text()
    text = re.sub(r"## Example.*?(?=\n## )", "", text, flags=re.S)
    for match in re.finditer(r"\b([A-Za-z_][\w.]*)\(([^()]*)\)", text):
        name, args = match.groups()
        for arg in args.split(","):
            key, sep, value = arg.partition("=")
            if not sep or not key.strip().isidentifier():
                continue
            try:
                literal = ast.literal_eval(value.strip())
            except (ValueError, SyntaxError):
                continue
            yield name, key.strip(), literal


def _resolve(name):
    import safe_legged_c3bf.c3bf as c3bf

    obj = c3bf
    parts = name.split(".")
    if not hasattr(c3bf, parts[0]):
        obj = c3bf.UnicycleModel  # model methods are documented without their class
    for part in parts:
        obj = getattr(obj, part, None)
    return obj


def test_documented_defaults_match_the_code():
    import inspect

    checked = 0
    for name, key, value in _documented_defaults():
        obj = _resolve(name)
        if obj is None or not callable(obj):
            continue
        params = inspect.signature(obj).parameters
        if key not in params:
            continue
        assert params[key].default == value, f"doc: {name}({key}={value!r}), code: " \
            f"{params[key].default!r}"
        checked += 1
    assert checked >= 15, checked
