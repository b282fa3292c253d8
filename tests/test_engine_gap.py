"""A PLC link outage mid-run (the PLC's Modbus server goes away and comes back on the same
port) becomes a `plc_link_gap` interruption with its start and end in run time; the slots
it swallowed are counted as missed, never filled; the run goes on. In one process: the PLC
stand-in on a small fake joint paced at 5 rig s per wall s, no drives."""

from __future__ import annotations

import asyncio
import threading

from daq.engine import Engine
from daq.plans import Plan
from daq.rig import Rig
from db.store import Store
from drivers_fake_live import FakeLiveJoint
from daq.settings import Settings
from simulators.plc import PlcProgram, PlcServer

SCALE = 5.0


def test_plc_link_gap_is_an_interruption_and_the_run_goes_on(tmp_path):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    plan = Plan.of(1, motor_speed_rpm=3000.0, load_target=20e3, ramp_rate=4e3)
    live, lock = FakeLiveJoint(), threading.RLock()
    program = PlcProgram(live, lock, watchdog_s=3.0)
    store = Store(url)

    async def main():
        srv = PlcServer(program, "127.0.0.1", 0)
        port = await srv.start()

        async def pace():
            while True:
                with lock:
                    live.advance(0.005 * SCALE)
                await asyncio.sleep(0.005)
        pacer = asyncio.create_task(pace())
        settings = Settings(plc_port=port, node_ids=(), plc_poll_hz=200.0, plc_link_timeout=3.0)
        engine = Engine(Rig(settings), store)
        task = asyncio.create_task(engine.run(plan))
        try:
            while engine.n_samples < 30 and not task.done():
                await asyncio.sleep(0.01)
            await srv.stop()                    # the PLC goes away ...
            await asyncio.sleep(0.4)
            srv = PlcServer(program, "127.0.0.1", port)
            await srv.start()                   # ... and comes back on the same port
            return engine, await task
        finally:
            pacer.cancel()
            await srv.stop()
    try:
        engine, out = asyncio.run(main())
    finally:
        store.close()
    assert out.exit_status == "success", out
    assert engine.skipped_writes > 0            # set points met the outage and were retried
    assert out.n_samples + out.missed == plan.n_samples()
    with Store(url) as store:
        (gap,) = store.interruptions(out.run_id)
        assert gap["kind"] == "plc_link_gap" and "answering again" in gap["reason"]
        span = gap["t_end"] - gap["t_start"]
        assert 0.4 * SCALE * 0.8 < span < 3.0 * SCALE
        d = store.load_arrays(out.run_id)
        inside = (d["t"] > gap["t_start"] + 0.1) & (d["t"] < gap["t_end"] - 0.1)
        assert not inside.any()                 # nothing invented inside the gap
        assert out.missed >= int(0.8 * span * plan.sample_rate_hz) - 1
        assert d["t"][-1] > plan.duration - 0.5  # and the run went on to its end
        assert store.channels(out.run_id)[-2:] == [
            {"name": "phase", "unit": "", "source": "plan:scheme1", "kind": "phase"},
            {"name": "w_cmd", "unit": "rad/s", "source": "plan:scheme1", "kind": "float"}]
