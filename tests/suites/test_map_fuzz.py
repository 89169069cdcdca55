"""Issue 13: any bytes in a map file give a GridMap or a one-line MapError naming the file —
never another exception; maps beyond the stated size limit are refused before any work."""

from __future__ import annotations

import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mirl.world.catalog import load_map
from mirl.world.maps import MAX_MAP_SIDE, GridMap, MapError

_PIECES = ["L", "G", "g", ".", "#", "\n", "\r\n", ";", " ", "\t", "\x00", "\ufeff", "\u2028",
           "é", "\x0b", "L.G\n", "...\n", "#.#\n"]  # fmt: skip


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    data=st.one_of(
        st.binary(max_size=200),
        st.lists(st.sampled_from(_PIECES), max_size=40).map(lambda p: "".join(p).encode()),
    ),
    suffix=st.sampled_from([".txt", ".map", ".yaml"]),
)
def test_any_bytes_give_a_map_or_map_error(tmp_path_factory, data, suffix):
    path = tmp_path_factory.mktemp("fuzz") / f"m{suffix}"
    path.write_bytes(data)
    try:
        gm = load_map(path)
    except MapError as exc:
        assert "\n" not in str(exc) and str(path) in str(exc)
    else:
        assert isinstance(gm, GridMap) and gm.n_patroller_cells >= 2


def test_a_5000_by_5000_map_is_refused_quickly(tmp_path):
    path = tmp_path / "huge.txt"
    path.write_text("L" + "." * 4999 + "\nG" + "." * 4999 + "\n" + ("." * 5000 + "\n") * 4998)
    start = time.perf_counter()
    with pytest.raises(MapError, match=rf"5000x5000 cells is larger than the limit of "
                       rf"{MAX_MAP_SIDE}x{MAX_MAP_SIDE}"):  # fmt: skip
        load_map(path)
    assert time.perf_counter() - start < 30  # bounded, not a timing assertion on speed
