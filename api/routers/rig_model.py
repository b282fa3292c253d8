"""/rig-model: the stored fit marked as the rig's current model (operator marks, anyone signed
in reads). The live twin of the acquisition event stream predicts the joint torque with it."""

from __future__ import annotations

from datetime import datetime

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, ConfigDict, Field

from api.deps import ERRORS, MAX_ID, Operator, StoreDep, Viewer

router = APIRouter(prefix="/rig-model", tags=["rig model"], responses=ERRORS)


class RigModelAnswer(BaseModel):
    """The rig's current model: the fit, its model and method, its parameters' posterior means
    (SI units as stated), who marked it and when."""
    fit_id: int
    model: str
    method: str
    params: dict[str, float]
    units: dict[str, str]
    sigma: float | None
    marked_by: str
    marked_at: datetime
    training_run_ids: list[int] = Field(description="the runs the fit was made on")


class MarkRigModel(BaseModel):
    model_config = ConfigDict(extra="forbid")
    fit_id: int = Field(ge=1, le=MAX_ID, description="a stored fit (GET /jobs/{id}/results, "
                                                     "`rig fits`)")


def _answer(store, cur: dict) -> RigModelAnswer:
    from db.fits import get_fit
    rec = get_fit(store, cur["fit_id"]) or {}
    train = [r["run_id"] for r in rec.get("runs", []) if r.get("role") == "train"]
    return RigModelAnswer(**cur, training_run_ids=train)


@router.get("", response_model=RigModelAnswer, summary="The rig's current model (404: none marked)")
def get_rig_model(store: StoreDep, _: Viewer) -> RigModelAnswer:
    from db.rig_model import current_rig_model
    cur = current_rig_model(store)
    if cur is None:
        raise HTTPException(404, "no fit is marked as the rig's model (PUT /rig-model)")
    return _answer(store, cur)


@router.put("", response_model=RigModelAnswer,
            summary="Mark a stored fit as the rig's model (the live twin predicts with it)")
def put_rig_model(body: MarkRigModel, store: StoreDep, caller: Operator) -> RigModelAnswer:
    from db.rig_model import NoSuchFit, mark_rig_model
    from estimator.twin import Twin, TwinUnavailable
    from db.fits import get_fit

    rec = get_fit(store, body.fit_id)
    if rec is None:
        raise HTTPException(404, f"no fit {body.fit_id}")
    params = {p["name"]: p["mean"] for p in (rec.get("fit") or {}).get("params", [])}
    try:
        Twin(rec["model"], params)
    except TwinUnavailable as e:
        raise HTTPException(422, f"fit {body.fit_id} cannot be the rig's model: {e}") from None
    try:
        cur = mark_rig_model(store, body.fit_id, caller.name)
    except NoSuchFit:
        raise HTTPException(404, f"no fit {body.fit_id}") from None
    return _answer(store, cur)
