"""Secrets out of text: the one helper that masks a password in a URL (or a `password=` item)
wherever a URL or a message that may hold one is printed, logged or answered.

    >>> redact_secrets("postgresql+psycopg://rig:s3cret@db.lan/rig")
    'postgresql+psycopg://rig:***@db.lan/rig'

The database URL itself travels only by environment (RIG_DB_URL) or settings file, never on a
command line; this is the second line of defence for what gets printed.
"""

from __future__ import annotations

import re

MASK = "***"

_USERINFO = re.compile(r"(?P<pre>\b[A-Za-z][A-Za-z0-9+.\-]*://[^\s:/@]*:)[^\s@]*@")
"""scheme://user:PASSWORD@ — the password runs to the first '@' (URLs percent-encode theirs)."""
_KEYWORD = re.compile(r"(?i)(?P<pre>\bpassword\s*=\s*)[^\s&;,'\"]*")
"""password=VALUE, as a URL query item (?password=...) or a libpq key-value string."""


def redact_secrets(text: str) -> str:
    """`text` with every URL password and `password=` value replaced by '***'."""
    text = _USERINFO.sub(lambda m: m.group("pre") + MASK + "@", text)
    return _KEYWORD.sub(lambda m: m.group("pre") + MASK, text)
