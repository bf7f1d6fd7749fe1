"""The viewer in a real browser: headless Chromium, driven by Selenium, opens the pages
that :func:`topojax.write_view` wrote, from disk, and the tests look at what it drew
(pixels of a screenshot), hover and click with the mouse, switch layers and step the
timeline.  Routes planned in the page must have :func:`topojax.plan_route`'s length to
1 mm.

Needs ``chromium`` and ``chromedriver`` on the PATH (Debian: ``apt-get install chromium
chromium-driver``) and ``pip install selenium``; without them the tests are skipped,
except in CI (``CI=true``), where they fail.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import time

import cv2
import numpy as np
import pytest
from brute_force import segment_pixels_exact
from view_cases import crossing_graph, intel_replay, intel_result, office_route_graph, wall_between

import topojax as tj

IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")

ORANGE = (230, 85, 13)  # the first graph
BLUE_SKELETON = (40, 90, 255)
BACKGROUND = (236, 239, 241)


def _missing() -> str | None:
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install selenium)"
    if _chromium() is None:
        return "no chromium / chromium-browser / google-chrome on the PATH"
    if shutil.which("chromedriver") is None:
        return "no chromedriver on the PATH (Debian: apt-get install chromium-driver)"
    return None


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def browser():
    reason = _missing()
    if reason is not None:
        if IN_CI:
            pytest.fail(f"the browser tests must run in CI: {reason}")
        pytest.skip(reason)
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = _chromium()
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        "--disable-gpu",
        "--window-size=1200,800",
        "--force-device-scale-factor=1",
    ):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    driver.set_script_timeout(60)
    try:
        yield driver
    finally:
        driver.quit()


def _open(driver, path) -> str:
    driver.get(path.resolve().as_uri())
    state = None
    for _ in range(1200):  # up to a minute on a busy machine
        state = driver.execute_script("return window.topojaxView && window.topojaxView.state")
        if state in ("ready", "error"):
            break
        time.sleep(0.05)
    return state


def _js(driver, code: str, *args):
    return driver.execute_script(f"return {code}", *args)


def _canvas_rgb(driver) -> np.ndarray:
    """The canvas as drawn: RGB (H, W, 3) uint8."""
    rect = _js(driver, "document.getElementById('tj-canvas').getBoundingClientRect().toJSON()")
    png = np.frombuffer(driver.get_screenshot_as_png(), np.uint8)
    img = cv2.imdecode(png, cv2.IMREAD_COLOR)[:, :, ::-1]
    x, y = int(rect["left"]), int(rect["top"])
    return img[y : y + int(rect["height"]), x : x + int(rect["width"])]


def _next_frame(driver) -> None:
    """Wait for the page's next animation frame: a draw asked for before (the page draws
    in ``requestAnimationFrame``) has then run, however long a busy machine takes."""
    driver.execute_async_script(
        "var done = arguments[arguments.length - 1]; requestAnimationFrame(function () { done(); });"
    )


def _count(img: np.ndarray, rgb, tol: int = 30) -> int:
    return int(np.all(np.abs(img.astype(int) - rgb) <= tol, axis=2).sum())


def _move(driver, sx: float, sy: float, click: bool = False) -> None:
    """Move the mouse to canvas point (sx, sy) (CSS pixels from its top-left)."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    canvas = driver.find_element(By.ID, "tj-canvas")
    w, h = canvas.size["width"], canvas.size["height"]
    chain = ActionChains(driver).move_to_element_with_offset(
        canvas, int(round(sx - w / 2)), int(round(sy - h / 2))
    )
    if click:
        chain = chain.click()
    chain.perform()


@pytest.fixture(scope="module")
def res():
    return intel_result()


@pytest.fixture(scope="module")
def intel_page(res, tmp_path_factory):
    return tj.write_view(res, tmp_path_factory.mktemp("view") / "intel.html")


@pytest.fixture()
def intel(browser, intel_page):
    assert _open(browser, intel_page) == "ready", _js(browser, "topojaxView.error")
    return browser


def test_map_and_graph_are_drawn_without_network(intel):
    img = _canvas_rgb(intel)
    assert _count(img, ORANGE) > 2000  # the graph's edges
    assert _count(img, (0, 0, 0), 40) > 2000  # the map's walls
    assert _count(img, (254, 254, 254), 2) > 50_000  # its free space
    fetched = _js(intel, "performance.getEntriesByType('resource').map(e => e.name)")
    assert all(name.startswith(("data:", "blob:")) for name in fetched), fetched
    assert _js(intel, "topojaxView.stats.first_draw_ms") > 0
    assert _js(intel, "document.getElementById('tj-error').hidden")


def test_layer_switches(intel):
    from selenium.webdriver.common.by import By

    before = _canvas_rgb(intel)
    intel.find_element(By.ID, "tj-layer-graph").click()
    no_graph = _canvas_rgb(intel)
    assert _count(no_graph, ORANGE) == 0 < _count(before, ORANGE)
    assert _count(no_graph, BLUE_SKELETON) < 50
    intel.find_element(By.ID, "tj-layer-skeleton").click()
    assert _count(_canvas_rgb(intel), BLUE_SKELETON) > 1000
    intel.find_element(By.ID, "tj-layer-map").click()
    no_map = _canvas_rgb(intel)
    # left: the scale bar, the coordinates and the vertices (white outlines)
    assert _count(no_map, (0, 0, 0), 40) < 0.1 * _count(before, (0, 0, 0), 40)
    assert _count(no_map, (254, 254, 254), 2) < 0.05 * _count(before, (254, 254, 254), 2)
    assert _count(no_map, BACKGROUND, 3) > 0.5 * no_map.shape[0] * no_map.shape[1]
    layers = {layer["name"]: layer["on"] for layer in _js(intel, "topojaxView.layers()")}
    assert layers["graph"] is False and layers["skeleton"] is True and layers["map"] is False


def _lonely_junction(graph, min_gap_m: float):
    """A junction whose nearest other vertex is at least ``min_gap_m`` away."""
    nodes = list(graph.nodes(data=True))
    xy = np.array([d["world"] for _, d in nodes])
    for i, (n, d) in enumerate(nodes):
        gap = np.hypot(*(xy - xy[i]).T)
        gap[i] = np.inf
        if d["kind"] == "junction" and gap.min() >= min_gap_m:
            return n, d
    raise AssertionError("no lonely junction")


def test_hovering_a_vertex_shows_its_clearance(intel, res):
    from selenium.webdriver.common.by import By

    n, d = _lonely_junction(res.graph, 1.5)
    sx, sy = _js(intel, "topojaxView.worldToScreen(arguments[0], arguments[1])", *d["world"])
    _move(intel, sx, sy)
    tip = intel.find_element(By.ID, "tj-tooltip")
    assert tip.is_displayed()
    text = tip.text
    assert f"vertex {n} · junction" in text
    assert f"clearance {d['clearance_m']:.3f} m" in text
    assert f"x {d['world'][0]:.3f} m, y {d['world'][1]:.3f} m" in text
    coords = intel.find_element(By.ID, "tj-coords").text
    x, y = (float(v) for v in coords.replace("x", "").replace("m", "").split("y"))
    assert math.hypot(x - d["world"][0], y - d["world"][1]) < 0.1  # a screen pixel or so


def _tooltip(driver) -> str | None:
    """The tooltip's text, or None while it is hidden."""
    from selenium.webdriver.common.by import By

    tip = driver.find_element(By.ID, "tj-tooltip")
    return tip.text if tip.is_displayed() else None


def _hover_text(driver, sx: float, sy: float) -> str | None:
    """What the tooltip should say at canvas point (sx, sy) of the view drawn now."""
    hover = _js(driver, "topojaxView.hoverAt(arguments[0], arguments[1])", sx, sy)
    return None if hover is None else "\n".join(hover["lines"])


def test_the_tooltip_follows_a_wheel_zoom_under_a_still_mouse(intel, res):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.by import By

    # zoomed in on a lonely junction, the mouse 20 px off it where nothing is under it
    n, d = _lonely_junction(res.graph, 1.5)
    _js(
        intel,
        "topojaxView.zoomAt(4, ...topojaxView.worldToScreen(arguments[0], arguments[1]))",
        *d["world"],
    )
    jx, jy = _js(intel, "topojaxView.worldToScreen(arguments[0], arguments[1])", *d["world"])
    spots = [(jx + 20 * math.cos(a), jy + 20 * math.sin(a)) for a in np.linspace(0, 6, 12)]
    sx, sy = next(p for p in spots if _hover_text(intel, *p) is None)
    _move(intel, sx, sy)
    assert _tooltip(intel) is None
    # the wheel zooms out about the mouse: the junction comes within reach of the hover
    canvas = intel.find_element(By.ID, "tj-canvas")
    w, h = canvas.size["width"], canvas.size["height"]
    origin = ScrollOrigin.from_element(canvas, int(round(sx - w / 2)), int(round(sy - h / 2)))
    ActionChains(intel).scroll_from_origin(origin, 0, 600).perform()
    _next_frame(intel)
    want = _hover_text(intel, sx, sy)
    assert want is not None and f"vertex {n} · junction" in want
    assert _tooltip(intel) == want


def test_the_tooltip_follows_the_timeline_under_a_still_mouse(browser, tmp_path):
    mapper, timeline, _ = intel_replay()
    page = tj.write_view(mapper, tmp_path / "replay.html", timeline=timeline)
    assert _open(browser, page) == "ready"
    # a vertex of the final graph with nothing of the first update under it
    for _, (x, y) in mapper.graph.nodes(data="world"):
        sx, sy = _js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", x, y)
        if not (0 < sx < 900 and 0 < sy < 700):
            continue
        _js(browser, "topojaxView.setFrame(0)")
        if _hover_text(browser, sx, sy) is not None:
            continue
        _js(browser, "topojaxView.setFrame(topojaxView.nFrames())")
        break
    else:
        raise AssertionError("no vertex of the final graph away from the first update's")
    _move(browser, sx, sy)
    assert "vertex" in _tooltip(browser)
    _js(browser, "topojaxView.setFrame(0)")  # as a replay playing steps to it
    _next_frame(browser)
    assert _tooltip(browser) is None
    _js(browser, "topojaxView.setFrame(topojaxView.nFrames())")
    _next_frame(browser)
    assert _tooltip(browser) == _hover_text(browser, sx, sy)


def test_hovering_an_edge_and_a_room(browser, res, tmp_path):
    from selenium.webdriver.common.by import By

    seg = tj.segment_rooms(res)
    page = tj.write_view(res, tmp_path / "rooms.html", rooms=seg)
    assert _open(browser, page) == "ready"
    # the middle pixel of the longest edge
    u, v, data = max(res.graph.edges(data=True), key=lambda e: e[2]["length_m"])
    mid = data["world"][len(data["world"]) // 2]
    _move(browser, *_js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", *mid))
    text = browser.find_element(By.ID, "tj-tooltip").text
    assert f"length {data['length_m']:.3f} m" in text
    assert f"min {data['min_clearance_m']:.3f} m, mean {data['mean_clearance_m']:.3f} m" in text
    # a room, with the graph off: the largest room at a free pixel of its own
    browser.find_element(By.ID, "tj-layer-graph").click()
    room = max(seg.rooms, key=lambda r: r.area_m2)
    rows, cols = np.nonzero(seg.labels == room.id)
    k = len(rows) // 2
    point = res.map.pixel_to_world(rows[k], cols[k])
    _move(browser, *_js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", *point))
    text = browser.find_element(By.ID, "tj-tooltip").text
    assert f"room {room.id}" in text and f"area {room.area_m2:.2f} m²" in text


def test_hovering_a_room_inside_another_names_the_inner_one(browser, res, tmp_path):
    """Rooms are drawn by their outer outline: where a room surrounds another (a ring of
    corridor round a courtyard room), the point belongs to the smaller room."""
    from selenium.webdriver.common.by import By

    from topojax.rooms import Room

    def square(x0, y0, side):
        return np.array([[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]])

    ring = Room(1, 300.0, (20.0, 20.0), square(5.0, 5.0, 30.0), (0, 0, 1, 1))
    inner = Room(2, 64.0, (20.0, 20.0), square(16.0, 16.0, 8.0), (0, 0, 1, 1))
    for rooms in ((ring, inner), (inner, ring)):  # whatever their order
        page = tj.write_view(res, tmp_path / "nested.html", rooms=(rooms, ()))
        assert _open(browser, page) == "ready"
        browser.find_element(By.ID, "tj-layer-graph").click()
        for point, room in (((20.0, 20.0), inner), ((8.0, 8.0), ring)):
            _move(
                browser,
                *_js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", *point),
            )
            text = browser.find_element(By.ID, "tj-tooltip").text
            assert f"room {room.id}" in text and f"area {room.area_m2:.2f} m²" in text


def test_hovering_the_hole_of_a_corridor_loop_names_the_room_inside(browser, res, tmp_path):
    """A corridor round a larger room: the point inside the corridor's outline but in its
    hole belongs to the room inside, though the corridor is the smaller room."""
    from selenium.webdriver.common.by import By

    from topojax.rooms import Room

    def square(x0, y0, side):
        return np.array([[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]])

    hole = square(7.0, 7.0, 26.0)[::-1].copy()  # clockwise
    loop = Room(1, 224.0, (20.0, 20.0), square(5.0, 5.0, 30.0), (0, 0, 1, 1), holes=(hole,))
    inner = Room(2, 676.0, (20.0, 20.0), square(7.0, 7.0, 26.0), (0, 0, 1, 1))
    page = tj.write_view(res, tmp_path / "loop.html", rooms=((loop, inner), ()))
    assert _open(browser, page) == "ready"
    browser.find_element(By.ID, "tj-layer-graph").click()
    for point, room in (((20.0, 20.0), inner), ((8.0, 20.0), inner), ((6.0, 20.0), loop)):
        _move(
            browser, *_js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", *point)
        )
        text = browser.find_element(By.ID, "tj-tooltip").text
        assert f"room {room.id}" in text and f"area {room.area_m2:.2f} m²" in text, point


def test_clicking_two_points_shows_the_length_of_plan_route(intel, res):
    from selenium.webdriver.common.by import By

    for start, goal in (((5.0, 30.0), (33.0, 5.0)), ((12.3, 4.1), (20.7, 28.2))):
        clicked = []
        for point in (start, goal):
            sx, sy = _js(intel, "topojaxView.worldToScreen(arguments[0], arguments[1])", *point)
            _move(intel, sx, sy, click=True)
            clicked.append(_js(intel, "topojaxView.routePoints().slice(-1)[0]"))
        want = tj.plan_route(res.graph, clicked[0], clicked[1])
        shown = intel.find_element(By.ID, "tj-route-length")
        assert abs(float(shown.get_attribute("data-length-m")) - want.length_m) < 1e-3
        assert shown.text == f"{want.length_m:.3f} m"
        _js(intel, "topojaxView.clearRoute()")


def test_routes_in_the_page_equal_plan_route(browser, res, tmp_path):
    pruned = tj.prune_graph(res.graph, min_clearance_m=0.3, min_spur_m=0.5, min_component_m=2.0)
    page = tj.write_view(res, tmp_path / "routes.html", graphs={"pruned": pruned})
    assert _open(browser, page) == "ready"
    rng = np.random.default_rng(7)
    h, w = res.map.shape
    corners = np.array(res.map.pixel_to_world([h - 1, 0], [0, w - 1])).T  # (x, y) lo, hi
    checked = failed = 0
    for name, graph in (("graph", res.graph), ("g1", pruned)):
        planner = tj.RoutePlanner(graph)
        pixels = np.concatenate([np.asarray(p) for *_, p in graph.edges(data="world")])
        for i in range(16):
            if i < 12:  # near the corridors, up to a metre off
                a, b = pixels[rng.integers(len(pixels), size=2)] + rng.uniform(-1, 1, (2, 2))
            else:  # anywhere on the map: some are too far from the graph
                a, b = rng.uniform(corners[0], corners[1], (2, 2))
            a, b = tuple(map(float, a)), tuple(map(float, b))
            got = _js(browser, "topojaxView.route(...arguments)", *a, *b, name)
            try:
                want = planner.route(a, b)
            except (ValueError, tj.NoRouteError) as exc:
                assert "error" in got, (a, b, exc)
                failed += 1
                continue
            assert "error" not in got, (a, b, got)
            assert abs(got["length_m"] - want.length_m) < 1e-3, (a, b)
            assert abs(got["start_snap_m"] - want.start_snap_m) < 1e-6
            assert abs(got["goal_snap_m"] - want.goal_snap_m) < 1e-6
            checked += 1
        # beside a vertex without edges (pruning leaves them): both snap to a corridor
        lonely = [d["world"] for n, d in graph.nodes(data=True) if graph.degree(n) == 0]
        for a in lonely[:3]:
            a = (float(a[0]) + 0.05, float(a[1]))
            b = tuple(map(float, pixels[len(pixels) // 2]))
            got = _js(browser, "topojaxView.route(...arguments)", *a, *b, name)
            want = planner.route(a, b)
            assert "error" not in got and abs(got["length_m"] - want.length_m) < 1e-3, (a, b)
            assert abs(got["start_snap_m"] - want.start_snap_m) < 1e-6
            checked += 1
    assert checked >= 12 and failed >= 1  # both outcomes agree
    far = _js(browser, "topojaxView.route(-100, -100, 10, 10, 'graph')")
    assert "more than the 5 m a route may snap" in far["error"]


@pytest.mark.parametrize("origin", [None, (3.7, -12.3, 0.4)])
def test_routes_on_a_route_graph_equal_plan_route(browser, tmp_path, origin):
    occupancy, routes = office_route_graph()
    if origin is not None:  # the same map turned and moved in the world
        occupancy = tj.OccupancyMap(
            occupancy.occupied, occupancy.free, occupancy.unknown, resolution_m=0.05, origin=origin
        )
        routes = tj.route_graph(occupancy)
    page = tj.write_view(routes, tmp_path / "route_graph.html", map=occupancy)
    assert _open(browser, page) == "ready"
    rng = np.random.default_rng(3)
    # shown with its map, the page joins routes to a route graph in sight, as the planner
    # given the map does
    planner = tj.RoutePlanner(routes, occupancy=occupancy)
    plain = tj.RoutePlanner(routes)
    points = np.concatenate([np.asarray(w) for *_, w in routes.edges(data="world")])
    checked = shorter = 0
    for _ in range(80):  # pairs in two of the graph's pieces have no route: draw on
        if checked == 24:
            break
        a, b = points[rng.integers(len(points), size=2)] + rng.uniform(-0.5, 0.5, (2, 2))
        a, b = tuple(map(float, a)), tuple(map(float, b))
        got = _js(browser, "topojaxView.route(...arguments)", *a, *b, "graph")
        try:
            want = planner.route(a, b)
        except (ValueError, tj.NoRouteError):
            assert "error" in got
            continue
        assert abs(got["length_m"] - want.length_m) < 1e-3, (a, b)
        assert abs(got["start_snap_m"] - want.start_snap_m) < 1e-6, (a, b)
        assert abs(got["goal_snap_m"] - want.goal_snap_m) < 1e-6, (a, b)
        base = plain.route(a, b)
        total = want.start_snap_m + want.length_m + want.goal_snap_m
        shorter += total < base.start_snap_m + base.length_m + base.goal_snap_m - 1e-6
        checked += 1
    assert checked >= 12 and shorter >= 1


def test_routes_from_where_edges_cross_equal_plan_route(browser, tmp_path):
    occupancy, g = crossing_graph()
    page = tj.write_view(g, tmp_path / "crossing.html", map=occupancy)
    assert _open(browser, page) == "ready"
    planner = tj.RoutePlanner(g)
    crossing = occupancy.pixel_to_world(5, 5)
    for end in ((0, 5), (5, 0), (10, 5), (5, 10), (2, 5), (5, 8), (9, 10)):
        end = occupancy.pixel_to_world(*end)
        for a, b in ((crossing, end), (end, crossing)):
            a, b = tuple(map(float, a)), tuple(map(float, b))
            got = _js(browser, "topojaxView.route(...arguments)", *a, *b, "graph")
            assert abs(got["length_m"] - planner.route(a, b).length_m) < 1e-9, (a, b)


def test_routes_from_where_the_robot_does_not_fit_equal_plan_route(browser, tmp_path):
    """A start closer to a wall than the robot's radius joins the graph in sight off the
    obstacles, and one in a closet the graph does not reach is refused, in the page as
    by the planner given the map."""
    from topojax.routegraph.feasible import feasible_space

    occupancy, g = wall_between(closet=True)
    page = tj.write_view(g, tmp_path / "wall.html", map=occupancy)
    assert _open(browser, page) == "ready"
    planner = tj.RoutePlanner(g, occupancy=occupancy)
    goal = tuple(map(float, occupancy.pixel_to_world(5, 25)))
    feasible = feasible_space(occupancy, 0.25).feasible
    for start in ((15, 19), (12, 19), (28, 21), (38, 5)):  # 0.1 m from a wall
        assert not feasible[start]  # the robot does not fit there
        a = tuple(map(float, occupancy.pixel_to_world(*start)))
        want = planner.route(a, goal)
        got = _js(browser, "topojaxView.route(...arguments)", *a, *goal, "graph")
        assert "error" not in got, (start, got)
        assert abs(got["length_m"] - want.length_m) < 1e-9, start
        assert abs(got["start_snap_m"] - want.start_snap_m) < 1e-9, start
    closet = tuple(map(float, occupancy.pixel_to_world(6, 15)))
    with pytest.raises(ValueError, match="behind an obstacle or off the map"):
        planner.route(closet, goal)
    got = _js(browser, "topojaxView.route(...arguments)", *closet, *goal, "graph")
    assert got["error"].startswith("start: the nearest point of the graph, 0.500000 m away, is ")
    assert "behind an obstacle or off the map, as is every other within 1.50000 m" in got["error"]


def test_an_end_as_near_to_two_points_of_an_edge_joins_as_the_planner_does(browser, tmp_path):
    """A start as near to two pixels of one edge, between rows 15 and 16 of the left edge
    with the goal at its lower end, may join at either: the page, as the planner given
    the map, joins at the one that gives the shorter route (row 16: 1.9 m along the
    graph), not at the first along the edge."""
    occupancy, g = wall_between()
    page = tj.write_view(g, tmp_path / "tie.html", map=occupancy)
    assert _open(browser, page) == "ready"
    a = tuple(map(float, occupancy.pixel_to_world(15.5, 11)))
    b = tuple(map(float, occupancy.pixel_to_world(35, 10)))
    want = tj.RoutePlanner(g, occupancy=occupancy).route(a, b)
    assert want.length_m == pytest.approx(1.9)
    got = _js(browser, "topojaxView.route(...arguments)", *a, *b, "graph")
    assert abs(got["length_m"] - want.length_m) < 1e-9, got
    assert abs(got["start_snap_m"] - want.start_snap_m) < 1e-9, got


def test_sight_lines_in_the_page_pass_the_planners_pixels(intel):
    """The page's router and RoutePlanner see along the same lines: random ones on a
    random grid, from anywhere to pixel centres, borders, corners and off the grid."""
    from topojax._sight import sees

    rng = np.random.default_rng(11)
    h, w = 23, 31
    feasible = rng.random((h, w)) < 0.92
    # (0, 0.7)-(3, 5) clips pixel (1, 3) at a corner, between samples half a pixel apart
    for r, c in segment_pixels_exact((0.0, 0.7), (3.0, 5.0)):
        feasible[r, c] = (r, c) != (1, 3)
    q = rng.uniform(-2.0, 33.0, (600, 2))
    p = q + rng.uniform(-6.0, 6.0, (600, 2))
    p[:400] = np.round(p[:400])  # graph pixels
    q[200:400] = np.round(q[200:400] * 2) / 2  # queries on pixel borders and corners
    q[400:], p[400:] = np.round(q[400:] * 4) / 4, np.round(p[400:] * 4) / 4
    q[0], p[0] = (0.0, 0.7), (3.0, 5.0)
    want = [bool(sees(feasible, a, b[None])[0]) for a, b in zip(q, p, strict=True)]
    got = _js(
        intel,
        "(function (h, w, bits, lines) {"
        " var F = {h: h, w: w, bits: Uint8Array.from(bits)};"
        " return lines.map(function (l) { return TJ.sees(F, l[0], l[1], l[2], l[3]); });"
        "})(...arguments)",
        h,
        w,
        np.packbits(feasible.ravel()).tolist(),
        np.concatenate([q, p], axis=1).tolist(),
    )
    assert not want[0] and 100 < sum(want) < len(want) - 100
    assert got == want


def test_pan_zoom_and_scale_bar(intel):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.by import By

    canvas = intel.find_element(By.ID, "tj-canvas")
    before = _js(intel, "topojaxView.view()")
    label = intel.find_element(By.ID, "tj-scale-label").text
    ActionChains(intel).scroll_from_origin(ScrollOrigin.from_element(canvas), 0, -600).perform()
    _next_frame(intel)  # the scale bar is drawn with the frame the zoom asks for
    zoomed = _js(intel, "topojaxView.view()")
    assert zoomed["z"] > 2 * before["z"]
    assert intel.find_element(By.ID, "tj-scale-label").text != label
    # the bar's length in pixels is its length in metres at the view's scale
    scale = zoomed["scale"]
    assert math.isclose(scale["pixels"], scale["metres"] / (0.05 / zoomed["z"]), rel_tol=1e-9)
    ActionChains(intel).move_to_element(canvas).click_and_hold().move_by_offset(
        80, 30
    ).release().perform()
    moved = _js(intel, "topojaxView.view()")
    assert abs(moved["tx"] - zoomed["tx"] - 80) < 6 and abs(moved["ty"] - zoomed["ty"] - 30) < 6
    assert _js(intel, "topojaxView.routePoints().length") == 0  # a drag is not a click


def test_the_timeline_steps(browser, tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    mapper, timeline, keys = intel_replay()
    page = tj.write_view(mapper, tmp_path / "replay.html", timeline=timeline)
    assert _open(browser, page) == "ready"
    assert _js(browser, "topojaxView.nFrames()") == 4
    assert _js(browser, "topojaxView.frameInfo()")["final"]
    final_img = _canvas_rgb(browser)
    slider = browser.find_element(By.ID, "tj-slider")
    label = browser.find_element(By.ID, "tj-frame")
    seen = []
    for _ in range(4):
        slider.send_keys(Keys.ARROW_LEFT)
        seen.append(_js(browser, "topojaxView.frameInfo()"))
    assert [f["index"] for f in seen] == [3, 2, 1, 0]
    first = seen[-1]
    assert first["edges"] == len(keys[0]) and first["added"] == len(keys[0])
    assert "update 1 of 4, scan 10" in label.text
    first_img = _canvas_rgb(browser)
    assert _count(first_img, ORANGE) < _count(final_img, ORANGE)
    assert _count(first_img, (27, 158, 62)) > 200  # the edges the update added
    slider.send_keys(Keys.ARROW_RIGHT)
    second = _js(browser, "topojaxView.frameInfo()")
    assert second["added"] == len(keys[1] - keys[0])
    assert second["removed"] == len(keys[0] - keys[1])
    assert f"−{second['removed']}" in label.text
    browser.find_element(By.ID, "tj-play").click()
    for _ in range(200):
        if _js(browser, "topojaxView.frameInfo()")["index"] > 1:
            break
        time.sleep(0.05)
    assert _js(browser, "topojaxView.frameInfo()")["index"] > 1


def test_a_broken_page_says_so(browser, intel_page, tmp_path):
    from selenium.webdriver.common.by import By

    text = intel_page.read_text()
    wrong = tmp_path / "version.html"
    wrong.write_text(text.replace('{"version":1,', '{"version":99,', 1))
    assert _open(browser, wrong) == "error"
    banner = browser.find_element(By.ID, "tj-error")
    assert banner.is_displayed() and "version 99" in banner.text
    corrupt = tmp_path / "corrupt.html"
    start = text.index('"vx":{"t":"f8","n":')
    z = text.index('"z":"', start) + 5
    corrupt.write_text(text[:z] + "AAAA" + text[z + 4 :])
    assert _open(browser, corrupt) == "error"
    assert "cannot be shown" in browser.find_element(By.ID, "tj-error").text


def test_hovering_an_edge_of_an_earlier_update_names_it(browser, tmp_path):
    # the edges an update removed stay in the timeline's pool; one lying under an edge of
    # the update shown must not hide that edge from the hover
    from view_cases import payload_of, unpacked

    mapper, timeline, _ = intel_replay()
    page = tj.write_view(mapper, tmp_path / "replay.html", timeline=timeline)
    assert _open(browser, page) == "ready"
    data = payload_of(page.read_text())["timeline"]
    sizes = unpacked(data["pool"]["sizes"])
    xy = unpacked(data["pool"]["xy"]).reshape(-1, 2)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    _js(browser, "topojaxView.setLayer('vertices', false)")
    for index, frame in enumerate(data["frames"]):
        _js(browser, "topojaxView.setFrame(arguments[0])", index)
        missed = []
        for e in unpacked(frame["edges"]).tolist():
            x, y = xy[(starts[e] + starts[e + 1]) // 2].tolist()
            sx, sy = _js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", x, y)
            hover = _js(browser, "topojaxView.hoverAt(arguments[0], arguments[1])", sx, sy)
            if hover is None or hover["kind"] != "edge":
                missed.append(e)
        assert missed == [], f"update {index}: edges {missed} not found under the mouse"


def test_a_cancelled_drag_stops_panning(intel):
    # the browser cancels a pointer (a touch the system takes over, a window losing the
    # pointer) without a pointerup: moves after it must not drag the map along
    before = _js(intel, "topojaxView.view()")
    intel.execute_script(
        """
        var c = document.getElementById('tj-canvas'), r = c.getBoundingClientRect();
        function send(type, x) {
          c.dispatchEvent(new PointerEvent(type, {pointerId: 7, button: 0, bubbles: true,
            clientX: r.left + x, clientY: r.top + 200}));
        }
        send('pointerdown', 200);
        send('pointercancel', 200);
        send('pointermove', 300);
        send('pointermove', 400);
        """
    )
    _next_frame(intel)
    after = _js(intel, "topojaxView.view()")
    assert (after["tx"], after["ty"]) == (before["tx"], before["ty"])


def test_a_click_over_a_given_route_starts_a_new_one(browser, res, tmp_path):
    from selenium.webdriver.common.by import By

    given = tj.plan_route(res.graph, (5.0, 30.0), (33.0, 5.0))
    page = tj.write_view(res, tmp_path / "given.html", route=given)
    assert _open(browser, page) == "ready"
    panel = browser.find_element(By.ID, "tj-route")
    assert f"{given.length_m:.3f} m" in panel.text
    sx, sy = _js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", 12.3, 4.1)
    _move(browser, sx, sy, click=True)
    # the start of a new route: the panel asks for its goal, and the given route is gone
    assert "click the goal" in panel.text
    assert f"{given.length_m:.3f}" not in panel.text
    assert _js(browser, "topojaxView.lastRoute()") is None


def test_last_route_tells_a_given_route_from_a_clicked_one(browser, res, tmp_path):
    # lastRoute() reports the route the panel shows: before any click that is route=,
    # said to be given; after two clicks, theirs
    given = tj.plan_route(res.graph, (5.0, 30.0), (33.0, 5.0))
    page = tj.write_view(res, tmp_path / "given.html", route=given)
    assert _open(browser, page) == "ready"
    shown = _js(browser, "topojaxView.lastRoute()")
    assert shown == {"length_m": pytest.approx(given.length_m), "given": True}
    for point in ((12.3, 4.1), (20.7, 28.2)):
        sx, sy = _js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", *point)
        _move(browser, sx, sy, click=True)
    clicked = _js(browser, "topojaxView.routePoints()")
    want = tj.plan_route(res.graph, *clicked)
    shown = _js(browser, "topojaxView.lastRoute()")
    assert shown == {"length_m": pytest.approx(want.length_m, abs=1e-3), "given": False}
    _js(browser, "topojaxView.clearRoute()")
    assert _js(browser, "topojaxView.lastRoute()") is None


def test_zooming_in_on_a_small_map_never_zooms_out(browser, tmp_path):
    # a map (or a window) of a few pixels fits the canvas at more screen pixels per map
    # pixel than the usual zoom limit
    free = np.ones((4, 4), bool)
    small = tj.OccupancyMap(~free, free, np.zeros_like(free), resolution_m=0.05)
    assert _open(browser, tj.write_view(small, tmp_path / "small.html")) == "ready"
    fitted = _js(browser, "topojaxView.view()")["z"]
    _js(browser, "topojaxView.zoomAt(2, 100, 100)")
    assert _js(browser, "topojaxView.view()")["z"] > fitted
    _js(browser, "topojaxView.zoomAt(0.5, 100, 100)")
    assert _js(browser, "topojaxView.view()")["z"] == pytest.approx(fitted)


def test_the_scale_bar_names_its_length_below_a_centimetre(browser, tmp_path):
    from selenium.webdriver.common.by import By

    free = np.ones((200, 200), bool)
    fine = tj.OccupancyMap(~free, free, np.zeros_like(free), resolution_m=0.005)
    assert _open(browser, tj.write_view(fine, tmp_path / "fine.html")) == "ready"
    for _ in range(8):
        _js(browser, "topojaxView.zoomAt(2, 300, 300)")
        metres = _js(browser, "topojaxView.view()")["scale"]["metres"]
        label = browser.find_element(By.ID, "tj-scale-label").text
        assert label.endswith(" m") and float(label[:-2]) == pytest.approx(metres), label


def test_hovering_a_vertex_of_a_second_graph_over_an_edge_of_the_first(browser, tmp_path):
    # vertices are drawn over every graph's edges, so the vertex under the mouse is named
    occupancy, routes = office_route_graph()
    res = tj.build_graph(occupancy)
    page = tj.write_view(res, tmp_path / "two.html", graphs={"routes": routes})
    assert _open(browser, page) == "ready"
    _js(browser, "topojaxView.zoomAt(3, 400, 300)")
    edge_points = np.concatenate([np.asarray(w) for *_, w in res.graph.edges(data="world")])
    first = np.array([w for _, w in res.graph.nodes(data="world")])
    z = _js(browser, "topojaxView.view()")["z"]
    tried = 0
    for _, (x, y) in routes.nodes(data="world"):
        near_edge = np.hypot(*(edge_points - (x, y)).T).min() < 4 * 0.05 / z  # 4 px
        far_vertex = np.abs(first - (x, y)).max(axis=1).min() > 10 * 0.05 / z  # 10 px
        if not (near_edge and far_vertex):
            continue
        sx, sy = _js(browser, "topojaxView.worldToScreen(arguments[0], arguments[1])", x, y)
        if not (0 < sx < 900 and 0 < sy < 640):
            continue
        hover = _js(browser, "topojaxView.hoverAt(arguments[0], arguments[1])", sx, sy)
        assert hover["kind"] == "vertex" and hover["lines"][0].startswith("routes vertex"), hover
        tried += 1
    assert tried > 0


def test_two_fingers_pinch_zoom_and_the_one_left_drags_on(intel):
    # on a touch screen two fingers zoom about their midpoint by the change of their
    # distance, and move the map with it; lifting one, the other drags on from where it
    # is (no jump), and lifting it is no click
    before = _js(intel, "topojaxView.view()")
    under = _js(intel, "topojaxView.screenToWorld(400, 200)")
    intel.execute_script(
        """
        var c = document.getElementById('tj-canvas'), r = c.getBoundingClientRect();
        window.sendTouch = function (type, id, x) {
          c.dispatchEvent(new PointerEvent(type, {pointerId: id, button: 0, bubbles: true,
            pointerType: 'touch', isPrimary: id === 11, clientX: r.left + x,
            clientY: r.top + 200}));
        };
        sendTouch('pointerdown', 11, 200);
        sendTouch('pointerdown', 12, 600);
        sendTouch('pointermove', 12, 700);
        sendTouch('pointermove', 12, 800);
        """
    )
    pinched = _js(intel, "topojaxView.view()")
    assert pinched["z"] == pytest.approx(1.5 * before["z"])  # 400 px apart, then 600
    # the point under the fingers' midpoint moved with it, from x 400 to 500
    assert _js(intel, "topojaxView.worldToScreen(arguments[0], arguments[1])", *under) == (
        pytest.approx([500, 200])
    )
    intel.execute_script(
        """
        sendTouch('pointerup', 12, 800);
        sendTouch('pointermove', 11, 220);
        sendTouch('pointermove', 11, 240);
        sendTouch('pointerup', 11, 240);
        """
    )
    _next_frame(intel)
    after = _js(intel, "topojaxView.view()")
    assert after["tx"] - pinched["tx"] == pytest.approx(40)
    assert (after["ty"], after["z"]) == (pinched["ty"], pinched["z"])
    assert _js(intel, "topojaxView.routePoints().length") == 0  # a pinch is no click


@pytest.mark.parametrize(
    ("call", "message"),
    [
        ("zoomAt(NaN, 100, 100)", "zoomAt: expected f, sx, sy as finite numbers, received f = NaN"),
        ("zoomAt(2)", "zoomAt: expected f, sx, sy as finite numbers, received sx = undefined"),
        ("zoomAt('2', 1, 1)", 'zoomAt: expected f, sx, sy as finite numbers, received f = "2"'),
        ("zoomAt(0, 100, 100)", "zoomAt: expected a zoom factor f > 0, received f = 0"),
        ("zoomAt(-2, 100, 100)", "zoomAt: expected a zoom factor f > 0, received f = -2"),
        ("panBy('5', 0)", 'panBy: expected dx, dy as finite numbers, received dx = "5"'),
        ("panBy(0, Infinity)", "panBy: expected dx, dy as finite numbers, received dy = Infinity"),
        (
            "worldToScreen('a', 3)",
            'worldToScreen: expected x, y as finite numbers, received x = "a"',
        ),
        (
            "screenToWorld(1)",
            "screenToWorld: expected sx, sy as finite numbers, received sy = undefined",
        ),
        ("hoverAt(NaN, 3)", "hoverAt: expected sx, sy as finite numbers, received sx = NaN"),
        # frames no number: the pan never ended
        (
            "benchmarkPan('a', 5)",
            'benchmarkPan: expected frames, dx as finite numbers, received frames = "a"',
        ),
    ],
)
def test_the_script_interface_refuses_what_is_no_point_by_name(intel, call, message):
    # a string or NaN would leave the view at no place (tx "126.2" + "5": the map gone)
    from selenium.common.exceptions import JavascriptException

    before = _js(intel, "topojaxView.view()")
    with pytest.raises(JavascriptException, match=re.escape(message)):
        _js(intel, f"topojaxView.{call}")
    assert _js(intel, "topojaxView.view()") == before


def test_a_route_between_points_that_are_no_numbers_is_refused_by_name(intel):
    got = _js(intel, "topojaxView.route(NaN, 0, 10, 10)")
    assert got == {"error": "route: expected x0, y0, x1, y1 as finite numbers, received x0 = NaN"}
    got = _js(intel, "topojaxView.route(5, 30)")
    assert got == {
        "error": "route: expected x0, y0, x1, y1 as finite numbers, received x1 = undefined"
    }


def test_a_layer_or_graph_the_page_has_not_is_refused_naming_those_it_has(intel):
    from selenium.common.exceptions import JavascriptException

    names = ", ".join(layer["name"] for layer in _js(intel, "topojaxView.layers()"))
    want = f'setLayer: expected a layer name ({names}), received "foo"'
    with pytest.raises(JavascriptException, match=re.escape(want)):
        _js(intel, "topojaxView.setLayer('foo', true)")
    # a switch is true or false: "false", or none, would turn the layer on or off unasked
    for on, shown in (("'false'", '"false"'), ("undefined", "undefined"), ("1", "1")):
        want = f"setLayer: expected on = true or false, received {shown}"
        with pytest.raises(JavascriptException, match=re.escape(want)):
            _js(intel, f"topojaxView.setLayer('graph', {on})")
    assert {layer["name"]: layer["on"] for layer in _js(intel, "topojaxView.layers()")}["graph"]
    got = _js(intel, "topojaxView.route(5, 30, 33, 5, 'nope')")
    assert got == {"error": 'route: expected graph, a graph layer\'s name (graph), received "nope"'}


def test_a_frame_that_is_no_number_is_refused(browser, tmp_path):
    from selenium.common.exceptions import JavascriptException

    mapper, timeline, _ = intel_replay()
    page = tj.write_view(mapper, tmp_path / "replay.html", timeline=timeline)
    assert _open(browser, page) == "ready"
    n = _js(browser, "topojaxView.nFrames()")
    for bad in ("NaN", "Infinity", "'2'", "null"):
        with pytest.raises(JavascriptException, match=r"setFrame: expected a frame index"):
            _js(browser, f"topojaxView.setFrame({bad})")
    with pytest.raises(JavascriptException, match=r'received "2"\n'):  # a string, quoted
        _js(browser, "topojaxView.setFrame('2')")
    assert _js(browser, "topojaxView.setFrame(arguments[0])", n + 5)["final"]  # clamped
    assert _js(browser, "topojaxView.setFrame(0)")["index"] == 0
