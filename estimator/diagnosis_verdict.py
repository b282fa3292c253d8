"""Verdicts of the gap diagnosis: one law's status from what was chosen and what structure is
left, and the merge of the output-side and the twist–torque laws' diagnoses into one verdict."""

from __future__ import annotations

from core.documents import DiagnosisReport
from estimator.diagnosis_coverage import coverage_note


def merge_transmission(report: DiagnosisReport, tx: DiagnosisReport) -> None:
    """Fold the transmission law's diagnosis `tx` into the output-side `report` (in place):
    `transmission` holds it whole; `candidates` gets its candidates, every row naming the
    `model` it was added to, best first by held-out shrinkage; the verdict lists both laws'
    effects (`effect_models` says which law each came from, `laws` each law's verdict) and is
    `unexplained` when either law is, `explained` when an effect was chosen, else `none`."""
    law0, law1 = report["baseline"]["model"], tx["baseline"]["model"]
    for c in report["candidates"]:
        c.setdefault("model", law0)
    for c in tx["candidates"]:
        c["model"] = law1
    report["candidates"] = sorted(report["candidates"] + tx["candidates"],
                                  key=lambda c: -c["shrinkage"])
    for row in tx["candidates"]:
        report["skipped"].pop(row["effect"], None)
    report["transmission"] = tx
    v, tv = report["verdict"], tx["verdict"]
    v["laws"] = {law0: {k: v[k] for k in ("status", "effects", "rmse_test_after", "model")},
                 law1: {k: tv[k] for k in ("status", "effects", "rmse_test_after", "model")}}
    v["effect_models"] = {**{e: law0 for e in v["effects"]},
                          **{e: law1 for e in tv["effects"] if e not in v["effects"]}}
    v["effects"] = v["effects"] + [e for e in tv["effects"] if e not in v["effects"]]
    v["shapes"] = {**tv["shapes"], **v["shapes"]}
    v["ambiguity_sets"] = {**tv.get("ambiguity_sets", {}), **v.get("ambiguity_sets", {})}
    if "angle_lag" in tv and v["effect_models"].get("time_delay") == law1:
        v["angle_lag"] = tv["angle_lag"]
    v["status"] = combined_status([v["status"], tv["status"]])


def outside_vocabulary(verdict: dict, effect: str, finding: str) -> None:
    """Take `effect` out of one law's `verdict` (in place) because the runs place its cause
    outside the vocabulary (`finding` says what it is): the effect leaves `effects` and
    `shapes`, the finding goes to `outside_vocabulary`, and the status is `partly_explained`
    when other effects stay, else `unexplained` — the structure the effect's columns removed
    is not a cause the vocabulary names."""
    if effect not in verdict["effects"]:
        return
    verdict["effects"] = [e for e in verdict["effects"] if e != effect]
    verdict["shapes"].pop(effect, None)
    verdict.get("ambiguity_sets", {}).pop(effect, None)
    verdict.setdefault("outside_vocabulary", []).append(finding)
    verdict["status"] = "partly_explained" if verdict["effects"] else "unexplained"


def combined_status(statuses: list[str]) -> str:
    """One verdict from the laws' verdicts: `none` when every law is `none`; `explained` when
    every law is `none` or `explained`; else `partly_explained` when some law named an effect
    (structure remains beside it), `unexplained` when none did."""
    if all(st == "none" for st in statuses):
        return "none"
    if all(st in ("none", "explained") for st in statuses):
        return "explained"
    if any(st in ("explained", "partly_explained") for st in statuses):
        return "partly_explained"
    return "unexplained"


def verdict_summary(report: DiagnosisReport) -> str:
    """The verdict in one sentence, the same in the text output and the JSON (verdict.summary):
    what was chosen, on which law, how far it shrinks that law's held-out error, what structure
    is left, and, when nothing was chosen, that no candidate is a cause; last, the inputs whose
    range the held-out runs cover too little to test an effect a nominal parameter absorbs."""
    v = report["verdict"]
    short = coverage_note(v.get("held_out_coverage") or {})
    if v["status"] == "none":
        return ("none — the residual is at the noise floor (no candidate effect improves the "
                "held-out error significantly)" + short)
    found = "".join(f"; {f}" for f in v.get("outside_vocabulary", []))
    laws = [(report, report["baseline"]["model"])]
    if report.get("transmission"):
        laws.append((report["transmission"], report["transmission"]["baseline"]["model"]))
    if not v["effects"]:
        # each law's own share: the merged verdict keeps the output law's, and a campaign the
        # twist–torque law alone leaves unexplained must not read as 0 % above the floor
        shares = ", ".join(f"{r['verdict'].get('structured_share_before', 0.0):.0%} on {law}"
                           for r, law in laws)
        return (f"unexplained — no effect of the vocabulary explains the gap (the part of the "
                f"held-out residual above the noise floor: {shares}); the flagged regions say "
                f"where it lies{found}{short}")
    parts = []
    models = v.get("effect_models") or {}
    sets = v.get("ambiguity_sets") or {}

    def name(e: str) -> str:
        # an effect whose contribution the runs cannot tell from another's is named with it
        entry = sets.get(e) or {}
        alike = entry.get("effects") or []
        text = f"{e} (≡ {' or '.join(alike)} on these runs)" if alike else e
        centre = entry.get("soft_centre")
        if centre:
            text += (f" (or a softer centre of the compliance curve: the dead zone's "
                     f"half-width, {centre['half_width_steps']:.1f} of the twist's stated steps, "
                     f"is under the {centre['steps_needed']:g} that tell the two apart)")
        lag = v.get("angle_lag") if e == "time_delay" else None
        if lag:
            late, other = (("q, the output angle", "u, the motor angle") if lag["reading"] == "q"
                           else ("u, the motor angle", "q, the output angle"))
            text += f" (an angle reading: {late}, read {1e3 * lag['lag_s']:.2g} ms after {other})"
        gain = entry.get("gain_mismatch")
        if gain:
            text += (f" (or a gain mismatch of {100 * gain['relative_gain_error']:.3g} % between "
                     f"the torque and load readings: the load never drove the joint in these "
                     f"runs, where the two are one column)")
        return text

    for rep, law in laws:
        named = [name(e) for e in v["effects"]
                 if models.get(e, report["baseline"]["model"]) == law]
        if not named:
            continue
        sh = rep["shrinkage"]["overall"]
        parts.append(f"{' + '.join(named)} (on {law}: held-out RMSE {sh['rmse_before']:.4g} -> "
                     f"{sh['rmse_after']:.4g}, shrinkage {sh['shrinkage']:.3f}, predicted from "
                     f"training {sh['predicted_from_training']:.3f})")
    text = f"{v['status']} — " + "; ".join(parts)
    if v["status"] == "partly_explained":
        left = max(r["verdict"].get("structured_share_after", 0.0) for r, _ in laws)
        text += f"; structure left: up to {left:.0%} of a law's residual above its noise floor"
    return text + found + short
