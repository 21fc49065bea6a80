"""Write examples/maps/floor_plan.{yaml,pgm}: a small floor plan that nodnav itself rasterises.

Two rooms (5 m x 6 m each) joined by a 2 m long, 0.7 m wide corridor through a thick wall, a
cupboard in the left room and a table in the right one, written at 0.05 m per cell in the ROS
map_server format (:func:`nodnav.scenario.maps.write_map`). ``floor_plan_crossing.yaml`` puts
robots on it; its passage is found on the map.

    .venv/bin/python examples/maps/write_floor_plan.py
"""

from pathlib import Path

from nodnav.scenario.maps import write_map
from nodnav.scenario.world import Passage, World

HERE = Path(__file__).parent


def floor_plan() -> World:
    """The plan as a World: outer walls 0.2 m thick, the dividing wall from x = -1 to x = 1."""
    return World(
        bounds=(-6.0, -3.0, 6.0, 3.0),
        obstacles=(
            (-6.0, -3.0, 6.0, -2.8), (-6.0, 2.8, 6.0, 3.0),    # outer walls, bottom and top
            (-6.0, -3.0, -5.8, 3.0), (5.8, -3.0, 6.0, 3.0),    # outer walls, left and right
            (-1.0, -2.8, 1.0, -0.35), (-1.0, 0.35, 1.0, 2.8),  # the dividing wall, pierced by the corridor
            (-5.8, 1.6, -4.6, 2.8),                            # a cupboard in the left room's corner
            (3.0, -1.6, 4.2, -0.8),                            # a table in the right room
        ),
        passages=(Passage(start=(-1.0, 0.0), end=(1.0, 0.0), width=0.7),),
    )


if __name__ == "__main__":
    print(f"wrote {write_map(floor_plan(), HERE / 'floor_plan.yaml', 0.05)}")
