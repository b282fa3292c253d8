"""The rig's current identified model: the stored fit an engineer marked as the rig's model
(`rig_models`, newest mark current). The console's live twin predicts the joint torque with it."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select

from db.models import Result, RigModel
from db.store import Store


class NoSuchFit(LookupError):
    """The fit to mark does not exist."""


def mark_rig_model(store: Store, result_id: int, by: str) -> dict[str, Any]:
    """Mark stored fit `result_id` as the rig's model; returns the current model's record."""
    with store.Session.begin() as s:
        if s.get(Result, result_id) is None:
            raise NoSuchFit(f"no fit {result_id}")
        s.add(RigModel(result_id=result_id, marked_by=by))
    cur = current_rig_model(store)
    assert cur is not None
    return cur


def current_rig_model(store: Store) -> dict[str, Any] | None:
    """{fit_id, model, method, params {name: mean}, units {name: unit}, sigma, marked_by,
    marked_at} of the newest mark, None when no fit was ever marked."""
    with store.ReadSession() as s:
        row = s.execute(select(RigModel, Result).join(Result, Result.id == RigModel.result_id)
                        .order_by(RigModel.id.desc()).limit(1)).first()
        if row is None:
            return None
        mark, res = row
        fit = res.fit or {}
        params = fit.get("params") or []
        return {"fit_id": res.id, "model": res.model, "method": res.method,
                "params": {p["name"]: p["mean"] for p in params},
                "units": {p["name"]: p.get("unit", "") for p in params},
                "sigma": fit.get("sigma"), "marked_by": mark.marked_by,
                "marked_at": mark.marked_at}
