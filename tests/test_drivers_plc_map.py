"""The register map (core/plc_map.py): layout rules, encoding and word order."""

import math
import struct
from dataclasses import replace

import pytest

from core.channels import CHANNELS
from core.plc_map import (COMMAND_BLOCK, MAX_READ_REGISTERS, MAX_WRITE_REGISTERS, REGISTER_MAP,
                         STATUS_BLOCK, Block, RegisterMap, Signal)


def test_layout_is_an_mb_server_db():
    m = REGISTER_MAP
    # one contiguous status block within one read, a separate command block within one write
    addr = m.status.start
    for s in m.status.signals:
        assert s.address == addr and s.access == "status"
        addr += s.width
    assert addr - m.status.start == m.status.count <= MAX_READ_REGISTERS
    assert m.command.count <= MAX_WRITE_REGISTERS
    assert m.command.start >= m.status.start + m.status.count
    assert all(s.access == "command" for s in m.command.signals)
    assert m.signals[m.heartbeat].access == "command"
    # the signals the issue lists are all there
    for name in ("pump_state", "valve_state", "p_hyd", "pressure_sp_applied", "torque", "q",
                 "torsion", "m_bend", "f_shear", "torque_cmd", "torque_load", "temp_joint",
                 "status_bits", "plc_mode", "fault_code", "heartbeat_echo", "plc_life",
                 "pressure_sp", "dyno_torque_sp", "valve_cmd", "command_bits"):
        assert name in m.signals, name
    for s in m.signals.values():
        assert s.channel is None or s.channel in CHANNELS
        if s.channel:
            assert s.unit == CHANNELS[s.channel].unit, s.name


def test_real_is_big_endian_high_word_first():
    s = REGISTER_MAP.signals["pressure_sp"]  # REAL in bar, scale 1e5
    regs = s.encode(123.25e5)
    raw = struct.pack(">f", 123.25)
    assert regs == [int.from_bytes(raw[:2], "big"), int.from_bytes(raw[2:], "big")]
    assert s.decode(regs) == pytest.approx(123.25e5)
    little = replace(s, word_order="little")
    assert little.encode(123.25e5) == regs[::-1]
    assert little.decode(regs[::-1]) == pytest.approx(123.25e5)


@pytest.mark.parametrize("order", ["big", "little"])
def test_every_signal_round_trips(order):
    m = REGISTER_MAP.with_word_order(order)
    for block in (m.status, m.command):
        values = {}
        for k, s in enumerate(block.signals):
            if s.dtype == "WORD":
                values[s.name] = float(0b1010_0101 + k)
            elif s.dtype in ("INT", "DINT"):
                values[s.name] = (-7 - k) * s.scale
            else:
                values[s.name] = (1.5 + k) * s.scale
        regs = block.encode(values)
        assert len(regs) == block.count and all(0 <= r <= 0xFFFF for r in regs)
        back = block.decode(regs)
        for name, v in values.items():
            assert back[name] == pytest.approx(v, rel=1e-6, abs=1e-12), name
    assert all(s.word_order == order for s in m.signals.values() if s.width == 2)


def test_missing_and_saturation():
    q = REGISTER_MAP.signals["q"]          # DINT encoder counts
    assert math.isnan(q.decode(q.encode(math.nan)))
    t = REGISTER_MAP.signals["plc_mode"]   # INT
    assert math.isnan(t.decode(t.encode(math.nan)))
    assert t.decode(t.encode(1e9)) == 32767    # saturates, never wraps
    assert t.decode(t.encode(-1e9)) == -32767
    r = REGISTER_MAP.signals["torque"]     # REAL carries NaN itself
    assert math.isnan(r.decode(r.encode(math.nan)))
    # the encoder count is 0.01°
    assert q.decode(q.encode(math.radians(12.34))) == pytest.approx(math.radians(12.34), abs=1e-9)


def test_bits():
    sb = REGISTER_MAP.signals["status_bits"]
    assert sb.bit("estop") == 1 and sb.bit("safe_state") == 4
    cb = REGISTER_MAP.signals["command_bits"]
    assert cb.bit("pump_on") == 1
    with pytest.raises(ValueError):
        cb.bit("nonsense")


def test_invalid_maps_are_refused():
    sig = STATUS_BLOCK.signals
    gap = Block("status", 0, STATUS_BLOCK.count + 1,
                sig[:1] + tuple(replace(s, address=s.address + 1) for s in sig[1:]))
    with pytest.raises(ValueError, match="contiguous"):
        RegisterMap(gap, COMMAND_BLOCK)
    big = tuple(Signal(f"x{i}", i, "INT", 1.0, "", "status", "") for i in range(126))
    with pytest.raises(ValueError, match="Modbus limit"):
        RegisterMap(Block("status", 0, 126, big), COMMAND_BLOCK)
    with pytest.raises(ValueError, match="overlap"):
        RegisterMap(STATUS_BLOCK, replace(COMMAND_BLOCK, start=0, signals=tuple(
            replace(s, address=s.address - 100) for s in COMMAND_BLOCK.signals)))
    with pytest.raises(ValueError, match="heartbeat"):
        RegisterMap(STATUS_BLOCK, COMMAND_BLOCK, heartbeat="nope")
    with pytest.raises(KeyError):
        COMMAND_BLOCK.encode({"no_such_signal": 1.0})
    with pytest.raises(ValueError):
        STATUS_BLOCK.decode([0] * 3)


def test_describe_lists_every_signal():
    rows = REGISTER_MAP.describe()
    assert {r["name"] for r in rows} == set(REGISTER_MAP.signals)
    assert all(r["word_order"] == "big" for r in rows)


def test_homing_bits_extend_the_words_without_moving_a_register():
    sb, cb = REGISTER_MAP.signals["status_bits"], REGISTER_MAP.signals["command_bits"]
    assert cb.bit("home") == 1 << 5
    assert sb.bit("homing") == 1 << 7 and sb.bit("homed") == 1 << 8
    # the earlier bits and every address stay where the PLC program has them
    assert sb.bit("fault_latched") == 1 << 6 and cb.bit("run") == 1 << 4
    assert (REGISTER_MAP.status.count, REGISTER_MAP.command.count) == (35, 7)
    assert REGISTER_MAP.signals["q"].address == 9
