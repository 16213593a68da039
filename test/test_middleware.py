"""The graph's processes publish asynchronously unless the user chose a mode."""

from __future__ import annotations

from safe_legged_c3bf.run.middleware import PUBLICATION_MODE, use_asynchronous_publishing


def test_asynchronous_publishing_is_the_default():
    env: dict[str, str] = {}
    assert use_asynchronous_publishing(env) == "ASYNCHRONOUS"
    assert env[PUBLICATION_MODE] == "ASYNCHRONOUS"


def test_a_mode_the_user_set_is_kept():
    env = {PUBLICATION_MODE: "SYNCHRONOUS"}
    assert use_asynchronous_publishing(env) == "SYNCHRONOUS"
    assert env[PUBLICATION_MODE] == "SYNCHRONOUS"
