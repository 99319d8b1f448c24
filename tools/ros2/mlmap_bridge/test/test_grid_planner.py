"""The planner example's search against brute force on small random grids (no ROS)."""

import math
import random

from mlmap_bridge.grid_planner import ESCAPE_COST, inflate, plan, shortest_path


def random_grid(rng, width, height, occupied, unknown):
    """Return OccupancyGrid-like data: 100, -1 or 0 per cell."""
    data = []
    for _ in range(width * height):
        r = rng.random()
        data.append(100 if r < occupied else -1 if r < occupied + unknown else 0)
    return data


def brute_blocked(data, width, height, radius_cells, unknown_free):
    """Blocked by definition: a source cell's centre within the radius."""
    sources = [(x, y) for y in range(height) for x in range(width)
               if data[y * width + x] > 50 or (data[y * width + x] < 0 and not unknown_free)]
    return [any(math.hypot(x - sx, y - sy) <= radius_cells + 1e-9 for sx, sy in sources)
            for y in range(height) for x in range(width)]


def brute_shortest(blocked, width, height, start, goal):
    """Dijkstra over every cell, the nearest open cell found by a scan; inf when unreachable."""
    dist = {(x, y): math.inf for y in range(height) for x in range(width)}
    dist[start] = 0.0
    todo = set(dist)
    while todo:
        cell = min(todo, key=lambda c: dist[c])
        if math.isinf(dist[cell]):
            break
        todo.remove(cell)
        x, y = cell
        out = blocked[y * width + x]
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                n = (x + dx, y + dy)
                if n == cell or n not in dist or (blocked[n[1] * width + n[0]] and not out):
                    continue
                if dx and dy and not out and (blocked[y * width + n[0]] or
                                              blocked[n[1] * width + x]):
                    continue
                step = (math.sqrt(2.0) if dx and dy else 1.0) * (ESCAPE_COST if out else 1.0)
                dist[n] = min(dist[n], dist[cell] + step)
    return dist[goal]


def test_inflation_marks_the_cells_within_the_radius_of_an_obstacle():
    """Every cell, against every source cell."""
    rng = random.Random(4)
    for trial in range(30):
        width, height = 8 + trial % 4, 6 + trial % 3
        data = random_grid(rng, width, height, 0.08, 0.15)
        radius = 0.5 * (trial % 5)
        unknown_free = trial % 2 == 0
        assert inflate(data, width, height, radius, unknown_free) == \
            brute_blocked(data, width, height, radius, unknown_free), trial


def test_a_star_finds_the_brute_force_shortest_length_through_free_cells():
    """Optimal lengths, consecutive steps, no blocked cell entered."""
    rng = random.Random(7)
    found = 0
    for trial in range(120):
        width, height = 9 + trial % 5, 7 + trial % 4
        blocked = inflate(random_grid(rng, width, height, 0.07, 0.2), width, height,
                          trial % 3, True)
        free = [(x, y) for y in range(height) for x in range(width) if not blocked[y * width + x]]
        if len(free) < 2:
            continue
        start, goal = rng.choice(free), rng.choice(free)
        result = shortest_path(blocked, width, height, start, goal)
        reference = brute_shortest(blocked, width, height, start, goal)
        assert (result is not None) == (not math.isinf(reference)), trial
        if result is None:
            continue
        found += 1
        cells, length = result
        assert abs(length - reference) < 1e-9, trial
        assert cells[0] == start and cells[-1] == goal
        for (ax, ay), (bx, by) in zip(cells, cells[1:]):
            assert max(abs(ax - bx), abs(ay - by)) == 1
            assert not blocked[by * width + bx]
    assert found > 60


def test_plan_runs_from_start_to_goal_round_a_wall_and_not_through_unknown_when_pessimistic():
    """World coordinates, the inflation in metres, the unknown-cell policy."""
    width, height, res = 20, 10, 0.2
    data = [0] * (width * height)
    for y in range(0, 8):
        data[y * width + 10] = 100   # a wall at x = 2.0-2.2 m, open above y = 1.6 m
    for y in range(8, 10):
        data[y * width + 10] = -1    # the opening not seen yet
    origin = (-1.0, 0.5)
    start, goal = (-0.5, 1.0), (2.5, 1.0)
    points = plan(data, width, height, res, origin, start, goal, radius_m=0.0)
    assert points[0] == start and points[-1] == goal
    assert max(y for _, y in points) > origin[1] + 1.6   # round the wall's end
    assert plan(data, width, height, res, origin, start, goal, 0.0, unknown_free=False) is None
    assert plan(data, width, height, res, origin, start, (5.0, 1.0), 0.0) is None  # outside
    # Inflated by 0.2 m one cell of the opening is left; by 0.4 m it closes.
    assert plan(data, width, height, res, origin, start, goal, radius_m=0.2) is not None
    assert plan(data, width, height, res, origin, start, goal, radius_m=0.4) is None
