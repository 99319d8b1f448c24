"""A shortest path on mlmap's 2D grid (nav_msgs/OccupancyGrid), for the planner example.

The same rules as mlmap's C++ reference planner (include/mlmap/nav/grid_search.h): cells within
the vehicle's radius of an occupied cell (value > 50) are blocked; unknown cells (-1) are free
(optimistic) unless ``unknown_free`` is False; 8-connected steps of one cell or sqrt(2) cells, no
diagonal step past the corner of a blocked cell, and a start inside a blocked zone leaves it by
the cheapest way (steps out of a blocked cell cost ESCAPE_COST times as much). No ROS: the
planner node (planner_node.py) wires it to topics, and the tests run it without ROS.
"""

import heapq
import math
from typing import List, Optional, Sequence, Tuple

ESCAPE_COST = 4.0
SQRT2 = math.sqrt(2.0)
STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))


def inflate(cells: Sequence[int], width: int, height: int, radius_cells: float,
            unknown_free: bool = True) -> List[bool]:
    """Return the blocked flag of every cell (row-major, as OccupancyGrid.data)."""
    reach = int(math.floor(radius_cells + 1e-9))
    disc = [(dx, dy) for dy in range(-reach, reach + 1) for dx in range(-reach, reach + 1)
            if dx * dx + dy * dy <= radius_cells * radius_cells + 1e-9]
    blocked = [False] * (width * height)
    for y in range(height):
        for x in range(width):
            value = cells[y * width + x]
            if not (value > 50 or (value < 0 and not unknown_free)):
                continue
            for dx, dy in disc:
                nx, ny = x + dx, y + dy
                if 0 <= nx < width and 0 <= ny < height:
                    blocked[ny * width + nx] = True
    return blocked


def shortest_path(blocked: Sequence[bool], width: int, height: int, start: Tuple[int, int],
                  goal: Tuple[int, int]) -> Optional[Tuple[List[Tuple[int, int]], float]]:
    """Return the cells from start to goal and the length in cells, or None (A*, octile)."""
    def inside(x, y):
        return 0 <= x < width and 0 <= y < height

    def octile(x, y):
        dx, dy = abs(x - goal[0]), abs(y - goal[1])
        return max(dx, dy) - min(dx, dy) + SQRT2 * min(dx, dy)

    if not inside(*start) or not inside(*goal):
        return None
    cost = {start: 0.0}
    parent = {start: None}
    done = set()
    heap = [(octile(*start), start)]
    while heap:
        _, cell = heapq.heappop(heap)
        if cell in done:
            continue
        done.add(cell)
        if cell == goal:
            break
        x, y = cell
        from_blocked = blocked[y * width + x]
        for dx, dy in STEPS:
            nx, ny = x + dx, y + dy
            if not inside(nx, ny) or (nx, ny) in done:
                continue
            if blocked[ny * width + nx] and not from_blocked:
                continue
            diagonal = dx != 0 and dy != 0
            if diagonal and not from_blocked and (blocked[y * width + nx] or
                                                  blocked[ny * width + x]):
                continue
            step = (SQRT2 if diagonal else 1.0) * (ESCAPE_COST if from_blocked else 1.0)
            if cost[cell] + step < cost.get((nx, ny), math.inf):
                cost[(nx, ny)] = cost[cell] + step
                parent[(nx, ny)] = cell
                heapq.heappush(heap, (cost[(nx, ny)] + octile(nx, ny), (nx, ny)))
    if goal not in done:
        return None
    path = []
    cell = goal
    while cell is not None:
        path.append(cell)
        cell = parent[cell]
    return path[::-1], cost[goal]


def plan(data: Sequence[int], width: int, height: int, resolution_m: float,
         origin_xy_m: Tuple[float, float], start_xy_m: Tuple[float, float],
         goal_xy_m: Tuple[float, float], radius_m: float,
         unknown_free: bool = True) -> Optional[List[Tuple[float, float]]]:
    """Return the path from start to goal as cell centres in the grid's frame [m], or None.

    The first point is the start and the last the goal themselves; None when either lies outside
    the grid or no path exists.
    """
    def cell_of(p):
        return (int(math.floor((p[0] - origin_xy_m[0]) / resolution_m)),
                int(math.floor((p[1] - origin_xy_m[1]) / resolution_m)))

    blocked = inflate(data, width, height, radius_m / resolution_m, unknown_free)
    found = shortest_path(blocked, width, height, cell_of(start_xy_m), cell_of(goal_xy_m))
    if found is None:
        return None
    points = [(origin_xy_m[0] + (x + 0.5) * resolution_m,
               origin_xy_m[1] + (y + 0.5) * resolution_m) for x, y in found[0]]
    points[0] = tuple(start_xy_m)
    points[-1] = tuple(goal_xy_m)
    return points
