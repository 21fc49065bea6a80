"""nodnav.heap: the long-lived heap frozen once per process, and nothing else changed."""

import gc
import weakref

from nodnav.heap import freeze_long_lived


def test_freezes_once_and_keeps_later_garbage_collectable():
    gc.unfreeze()
    try:
        assert freeze_long_lived() is True
        frozen = gc.get_freeze_count()
        assert frozen > 0  # the objects alive now (this interpreter's modules at least)
        assert freeze_long_lived() is False  # once per process: a second call leaves it as it is
        assert gc.get_freeze_count() == frozen

        # A reference cycle made after the freeze is still found by the collector. Automatic
        # collections are off meanwhile: a thread left by an earlier test (a worker pool's) could
        # otherwise collect the cycle first, which is why this once failed in a serial run.
        class Node:
            pass

        enabled = gc.isenabled()
        gc.disable()
        try:
            a, b = Node(), Node()
            a.other, b.other = b, a
            alive = weakref.ref(a)
            del a, b
            assert alive() is not None  # a cycle: reference counting alone does not free it
            gc.collect()
            assert alive() is None
        finally:
            if enabled:
                gc.enable()
    finally:
        gc.unfreeze()
