from __future__ import annotations

import gc
import weakref

from bracekit.report.frozen_heap import frozen_heap


class _Node:
    def __init__(self) -> None:
        self.me = self  # a reference cycle: only the collector frees it


def test_the_objects_alive_before_are_frozen_and_thawed_after() -> None:
    gc.collect()
    before = _Node()
    assert gc.get_freeze_count() == 0
    with frozen_heap():
        assert gc.get_freeze_count() > 0
        assert not any(o is before for o in gc.get_objects())  # out of every generation the collector walks
    assert gc.get_freeze_count() == 0
    assert any(o is before for o in gc.get_objects(generation=2))  # back in the oldest generation


def test_garbage_made_while_frozen_is_collected() -> None:
    with frozen_heap():
        ref = weakref.ref(_Node())
        gc.collect()
        assert ref() is None


def test_objects_frozen_by_the_caller_stay_frozen() -> None:
    gc.collect()
    kept = _Node()
    gc.freeze()
    try:
        count = gc.get_freeze_count()
        with frozen_heap():
            assert gc.get_freeze_count() == count
        assert gc.get_freeze_count() == count
        assert not any(o is kept for o in gc.get_objects())
    finally:
        gc.unfreeze()
