"""The motion model (docs/design.md, "Transition features") written out by hand, as the
independent reference the domain tests compare against."""

# heading 0 = east (col+1), 1 = north (row-1), 2 = west, 3 = south
DELTA = {0: (0, 1), 1: (-1, 0), 2: (0, -1), 3: (1, 0)}
FEATURES = ("left_wheel", "right_wheel", "navigation", "floor")
SPEC_XI = {
    "forward": {"left_wheel", "right_wheel", "navigation", "floor"},
    "turn_left": {"right_wheel", "navigation", "floor"},
    "turn_right": {"left_wheel", "navigation", "floor"},
    "stop": {"floor"},
}
