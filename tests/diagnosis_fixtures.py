"""A stored emulator campaign with a withheld effect, for the API tests of the diagnosis job kind
(tests/test_api_diagnosis.py, tests/test_api_browser.py): the campaign of
commands.diagnosis_harness (training and held-out runs each with both directions and both
speeds), gear ripple injected at an effect-to-noise ratio of about 2 (the magnitude of
tests/test_diagnosis.py), saved with Store.save_run."""

from __future__ import annotations

INJECTED = "gear_ripple"
INJECTED_PARAMS = {"A": 435.0}
"""Gear ripple amplitude [N·m], ENR ≈ 2 on this campaign (tests/test_diagnosis.py ENR2)."""
ORDER = 36
"""The emulator's gear ripple order (cycles per output revolution, core.effects default)."""


def store_campaign(store, seed: int = 3) -> tuple[list[int], list[int]]:
    """Simulate the campaign with the withheld effect and store it: (train ids, test ids)."""
    from commands.diagnosis_harness import simulate_campaign

    train, test = simulate_campaign({INJECTED: dict(INJECTED_PARAMS)}, seed)
    return ([store.save_run(r, exit_status="success") for r in train],
            [store.save_run(r, exit_status="success") for r in test])


def diagnosis_body(train: list[int], test: list[int], **extra) -> dict:
    """POST /jobs body of a diagnosis job."""
    return {"kind": "diagnosis", "params": {"run_ids": train, "test_run_ids": test, **extra}}
