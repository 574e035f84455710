"""Operators: scrypt password hashes (RFC 7914), the users file, sessions."""

from __future__ import annotations

import json
import stat
import time

import pytest

from ctrlblocks.web.auth import (
    SCRYPT,
    SessionStore,
    UserError,
    UserStore,
    hash_password,
    verify_password,
)


def test_scrypt_hash_equals_the_rfc_7914_test_vector():
    # RFC 7914, section 12: scrypt(P="password", S="NaCl", N=1024, r=8, p=16, dkLen=64)
    # starts fdbabe1c...; with dkLen=32 the first 32 bytes (PBKDF2 blocks are independent)
    rec = hash_password("password", salt=b"NaCl", n=1024, r=8, p=16)
    assert rec["hash"] == "fdbabe1c9d3472007856e7190d01e9fe7c6ad7cbc8237830e77376634b373162"
    assert rec["scrypt"] == {"n": 1024, "r": 8, "p": 16}
    assert verify_password("password", rec)
    assert not verify_password("Password", rec)


def test_default_cost_is_the_rfc_interactive_setting():
    assert SCRYPT == {"n": 2**14, "r": 8, "p": 1}
    rec = hash_password("correct horse")
    assert rec["scrypt"] == SCRYPT and len(bytes.fromhex(rec["salt"])) == 16
    assert verify_password("correct horse", rec)


def test_users_file_holds_no_password_and_only_its_owner_reads_it(tmp_path):
    path = tmp_path / "users.json"
    store = UserStore(path)
    store.add("alice", "s3cret-password", n=2**10)
    store.add("bob", "s3cret-password", n=2**10)
    text = path.read_text()
    assert "s3cret-password" not in text
    doc = json.loads(text)["users"]
    assert doc["alice"]["salt"] != doc["bob"]["salt"]  # a salt per user
    assert doc["alice"]["hash"] != doc["bob"]["hash"]  # same password, other hash
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    again = UserStore(path)
    assert again.names() == ["alice", "bob"] and again.role("alice") == "operator"
    assert again.verify("alice", "s3cret-password")
    assert not again.verify("alice", "wrong-password")
    assert not again.verify("carol", "s3cret-password")
    again.remove("bob")
    assert UserStore(path).names() == ["alice"]


@pytest.mark.parametrize(
    ("name", "password"),
    [("alice", "short"), ("bad name", "long enough"), ("", "long enough")],
)
def test_bad_user_names_and_short_passwords_are_refused(tmp_path, name, password):
    store = UserStore(tmp_path / "u.json")
    with pytest.raises(UserError):
        store.add(name, password, n=2**10)
    assert store.names() == [] and not (tmp_path / "u.json").exists()


def test_sessions_expire_and_end_at_logout(monkeypatch):
    s = SessionStore(hours=1.0)
    tok = s.create("alice", "operator")
    assert s.get(tok).user == "alice"
    assert s.get("forged") is None and s.get(None) is None
    s.end(tok)
    assert s.get(tok) is None
    tok = s.create("alice", "operator")
    now = time.time()
    monkeypatch.setattr(time, "time", lambda: now + 3601.0)
    assert s.get(tok) is None
