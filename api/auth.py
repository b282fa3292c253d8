"""API token roles: viewer < operator < rig-operator < admin. A token's role is stored in its
`scopes` list (db.tokens keeps only the SHA-256 hash of the secret).

- viewer: reads everything, and may e-stop a running acquisition (anyone signed in can stop
  the machine);
- operator: submits and cancels jobs; starts, stops schemes on the emulator;
- rig-operator: also starts schemes on the real rig (target 'rig');
- admin: also manages tokens.
"""

from __future__ import annotations

ROLES: tuple[str, ...] = ("viewer", "operator", "rig-operator", "admin")
"""In increasing order of rights: each role can do what the ones before it can."""
RIG_ROLE = "rig-operator"
"""The least role that may start a scheme on the real rig."""


def role_rank(role: str) -> int:
    """Position of `role` in ROLES; ValueError for an unknown role."""
    if role not in ROLES:
        raise ValueError(f"role must be one of {ROLES}, got {role!r}")
    return ROLES.index(role)


def role_of(scopes: list[str] | None) -> str | None:
    """The highest role named in a token's scopes (None: no role)."""
    known = [s for s in (scopes or []) if s in ROLES]
    return max(known, key=ROLES.index) if known else None


def allows(have: str | None, need: str) -> bool:
    """True when a token of role `have` may do what needs `need`."""
    return have is not None and role_rank(have) >= role_rank(need)
