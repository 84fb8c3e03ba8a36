"""studies/lp_timing.py's wall names: ``CxB`` with :func:`blockmpec.cases.wall` options after colons, parsed by the
CLI's own ``KEY=VALUE`` reader; a malformed or invalid option is one line naming it, not a traceback."""

import pytest
from helpers import load_study


def test_wall_names_take_case_options_after_colons():
    timing = load_study("lp_timing")
    wall = timing.wall_or_size("5x4:mu=0.3:bond=stack")
    assert (wall.metadata["courses"], wall.metadata["blocks_per_course"], wall.metadata["bond"]) == (5, 4, "stack")
    assert set(wall.interface_friction()) == {0.3}
    plain = timing.wall_or_size("5x4")
    assert plain.metadata["bond"] == "running" and set(plain.interface_friction()) == {0.65}


@pytest.mark.parametrize("name, message", [("5x4:mu", "option 'mu': expected KEY=VALUE"),
                                           ("5x4:bond=zig", "bond: must be 'running' or 'stack'")])
def test_a_bad_wall_option_is_one_line(name, message):
    timing = load_study("lp_timing")
    with pytest.raises(SystemExit, match=message):
        timing.wall_or_size(name)
