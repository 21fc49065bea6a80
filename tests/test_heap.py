"""nodnav.heap: the long-lived heap frozen once per process, and nothing else changed."""

import gc

from nodnav.heap import freeze_long_lived


def test_freezes_once_and_keeps_later_garbage_collectable():
    gc.unfreeze()
    try:
        assert freeze_long_lived() is True
        frozen = gc.get_freeze_count()
        assert frozen > 0  # the objects alive now (this interpreter's modules at least)
        assert freeze_long_lived() is False  # once per process: a second call leaves it as it is
        assert gc.get_freeze_count() == frozen

        # A reference cycle made after the freeze is still found by the collector.
        class Node:
            pass

        a, b = Node(), Node()
        a.other, b.other = b, a
        del a, b
        assert gc.collect() >= 2
    finally:
        gc.unfreeze()
