"""The drives' EDS (core/drives.eds) as canopen reads it: the CiA 402 objects the rig needs,
consistent PDO mappings, and the shared state coding (core/drive_od.py)."""

import canopen
import pytest
from canopen.objectdictionary import ODVariable

from core import drive_od as D


@pytest.fixture(scope="module")
def od():
    return canopen.import_od(str(D.EDS_PATH), 2)


def test_required_objects(od):
    for index in (0x1000, 0x1001, 0x1003, 0x1014, 0x1017, 0x1018, D.CONTROLWORD, D.STATUSWORD,
                  D.MODES_OF_OPERATION, D.MODES_DISPLAY, D.VELOCITY_ACTUAL, D.TARGET_VELOCITY,
                  D.TORQUE_ACTUAL, D.TARGET_TORQUE, D.CURRENT_ACTUAL, D.MOTOR_TEMPERATURE,
                  D.SAMPLE_STAMP, D.RATED_CURRENT, D.RATED_TORQUE, *D.TPDO_COMM, *D.TPDO_MAP,
                  *D.RPDO_COMM, *D.RPDO_MAP):
        assert index in od, hex(index)
    assert od[0x1000].default & 0xFFFF == 402           # device profile CiA 402
    assert od[0x1014].default == 0x80 + 2               # EMCY COB-ID follows the node id
    assert od[D.TPDO_COMM[0]][1].default == 0x180 + 2
    assert 0x2000 <= D.MOTOR_TEMPERATURE < 0x6000       # manufacturer-specific


@pytest.mark.parametrize("maps", [D.TPDO_MAP, D.RPDO_MAP])
def test_pdo_mappings_fit_and_are_mappable(od, maps):
    for m in maps:
        bits = 0
        for sub in range(1, od[m][0].default + 1):
            entry = od[m][sub].default
            index, subindex, length = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
            obj = od[index]
            if not isinstance(obj, ODVariable):
                obj = obj[subindex]
            assert obj.pdo_mappable, hex(index)
            assert len(obj) == length, hex(index)
            bits += length
        assert 0 < bits <= 64


def test_fast_tpdo_carries_speed_current_and_stamp(od):
    mapped = [od[D.TPDO_MAP[0]][s].default >> 16 for s in range(1, od[D.TPDO_MAP[0]][0].default + 1)]
    assert mapped == [D.VELOCITY_ACTUAL, D.CURRENT_ACTUAL, D.SAMPLE_STAMP]
    assert od[D.TPDO_COMM[0]][5].default == 1           # 1 ms event timer: 1 kHz
    rpdo1 = [od[D.RPDO_MAP[0]][s].default >> 16 for s in range(1, od[D.RPDO_MAP[0]][0].default + 1)]
    assert rpdo1 == [D.CONTROLWORD, D.TARGET_VELOCITY]


def test_state_coding_round_trips():
    for state in D.STATE_CODES:
        sw = D.statusword_for(state, D.SW_REMOTE | D.SW_VOLTAGE_ENABLED)
        assert D.state_of(sw) == state
    assert D.state_of(0x0237) == "OPERATION ENABLED"
    assert D.state_of(0x0008) == "FAULT"
