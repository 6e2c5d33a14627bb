"""PX4 mission items for MAVSDK's mission_raw: numbering, units, verification."""

import pytest

from aerosurvey.errors import InputError
from aerosurvey.link.px4 import compare, px4_items
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.builder import build_mission
from aerosurvey.inputs import plan_from_files
from aerosurvey.spec import load_spec
from conftest import make_spec


def test_px4_items_from_a_plan(tmp_path):
    plan = plan_from_files(load_spec(make_spec(tmp_path, {"vehicle": {"firmware": "px4"}, "flight": {"fixed_yaw_deg": 90.0}})))
    m = build_mission(plan)
    items = px4_items(m)
    assert [i.seq for i in items] == list(range(len(m.items)))  # no home item on PX4
    assert items[0].current == 1 and all(i.current == 0 for i in items[1:])
    wp = next(i for i, it in zip(items, m.items) if it.command == mav.NAV_WAYPOINT)
    src = next(it for it in m.items if it.command == mav.NAV_WAYPOINT)
    assert wp.x == round(src.x * 1e7) and wp.y == round(src.y * 1e7) and wp.param4 == 90.0
    assert compare(items, items) == []
    changed = list(items)
    changed[3] = type(items[3])(seq=3, frame=items[3].frame, command=items[3].command, current=0, autocontinue=1,
                                param1=items[3].param1 + 1, param2=items[3].param2, param3=items[3].param3,
                                param4=items[3].param4, x=items[3].x, y=items[3].y, z=items[3].z, mission_type=0)
    assert any(d.startswith("item 3: param1") for d in compare(items, changed))


def test_ardupilot_plan_is_refused_for_px4(tmp_path):
    m = build_mission(plan_from_files(load_spec(make_spec(tmp_path))))
    with pytest.raises(InputError, match="vehicle.firmware = 'px4'"):
        px4_items(m)
