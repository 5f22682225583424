// The map and the panel's words as a newcomer meets them (issue 22, "Minor"): a click sends the cart
// (Go here is the mode the map starts in) and a refused goal says why where the click was; a
// finished route is not drawn through a changed map; the camera's field of view stops at the walls
// and the obstacles; "Clear obstacles" after a confirmation; a link error's toast goes once the link
// is up; the command form sends a path of several points; the settings badge after Save.

import { expect, test, type Page, type WebSocketRoute } from "@playwright/test";

import { startGateway } from "./gateway";
import { BASE, clickMap, gotoAndWait, obstacles, open, pixel, pose, SHOTS, trustPose, type Point } from "./helpers";

test.describe.configure({ mode: "serial" });
test.beforeAll(({ request }) => trustPose(request));

const CHANGE = { headers: { Origin: BASE } }; // a change from the panel's own origin

async function setObstacle(page: Page, p: Point, present: boolean): Promise<void> {
  const r = await page.request.put(`${BASE}/api/map/obstacle`, { data: { x: p[0], y: p[1], present }, ...CHANGE });
  expect(r.ok(), await r.text()).toBe(true);
}

async function arena(page: Page): Promise<number[]> {
  return ((await page.locator("#map").getAttribute("data-arena")) ?? "").split(" ").map(Number);
}

async function fovExtent(page: Page): Promise<number[]> {
  return ((await page.locator("#map").getAttribute("data-fov-extent")) ?? "").split(" ").map(Number);
}

test("the map starts in Go here: a newcomer's first click sends the cart and adds no obstacle", async ({ page }) => {
  const w = await open(page);
  await expect(page.locator("#map")).toHaveAttribute("data-mode", "goto");
  await expect(page.locator('input[name="map-mode"][value="goto"]')).toBeChecked();
  await expect(page.locator("#map-hint")).toContainText("send the robot");
  const at = await pose(page);
  await clickMap(page, [at[0] < 1.0 ? at[0] + 0.3 : at[0] - 0.3, at[1]]);
  await expect.poll(() => w.requests).toContain("POST /api/goto");
  await expect(page.locator("body")).toHaveAttribute("data-mission", /driving|arrived/);
  expect(w.requests).not.toContain("PUT /api/map/obstacle");
  expect(await obstacles(page)).toEqual([]);
  await expect(page.locator("body")).toHaveAttribute("data-mission", "arrived", { timeout: 20_000 });
  expect(w.pageErrors).toEqual([]);
});

test("a refused click-goal says why on the map, in view, in a 1400 × 1000 window", async ({ browser }) => {
  const context = await browser.newContext({ viewport: { width: 1400, height: 1000 } });
  const page = await context.newPage();
  const w = await open(page);
  const node: Point = [1.0, 1.0];
  await setObstacle(page, node, true);
  try {
    await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "1");
    await clickMap(page, node); // in Go here mode: a goal inside the obstacle
    const said = page.locator("#map-msg");
    await expect(said).toBeVisible();
    await expect(said).toHaveClass(/form-error/);
    await expect(said).toContainText("obstacle"); // the gateway's sentence
    const box = await said.boundingBox();
    expect(box).not.toBeNull();
    if (box) expect(box.y + box.height).toBeLessThanOrEqual(1000); // on screen, without scrolling
    expect(await page.evaluate(() => window.scrollY)).toBe(0);
    // said once: not again in the line under the map, nor as a toast
    await expect(page.locator("#goto-msg")).toHaveText("");
    await expect(page.locator("#messages .msg")).toHaveCount(0);
    await page.screenshot({ path: `${SHOTS}/goal-refused-on-map.png` });
    await said.click(); // a click takes it away
    await expect(said).toBeHidden();
  } finally {
    await setObstacle(page, node, false);
  }
  expect(w.pageErrors).toEqual([]);
  await context.close();
});

test("a finished route is not drawn through new obstacles or a new map", async ({ page }) => {
  const w = await open(page);
  const at = await pose(page);
  const goal: Point = Math.hypot(at[0] - 0.4, at[1] - 0.4) > 0.1 ? [0.4, 0.4] : [0.8, 0.4];
  await gotoAndWait(page, goal);
  await expect.poll(async () => Number(await page.locator("#map").getAttribute("data-plan"))).toBeGreaterThan(0);
  // an obstacle elsewhere: the route drawn was planned on the map before it
  await setObstacle(page, [1.6, 1.6], true);
  try {
    await expect(page.locator("#map")).toHaveAttribute("data-plan", "0");
    await page.waitForTimeout(1500); // status polls (every second) bring the same plan back: it stays hidden
    await expect(page.locator("#map")).toHaveAttribute("data-plan", "0");
    // the next route is drawn again
    await gotoAndWait(page, [goal[0], goal[1] + 0.2]);
    await expect.poll(async () => Number(await page.locator("#map").getAttribute("data-plan"))).toBeGreaterThan(0);
  } finally {
    await setObstacle(page, [1.6, 1.6], false);
  }
  await expect(page.locator("#map")).toHaveAttribute("data-plan", "0"); // taking it away changes the map too
  expect(w.pageErrors).toEqual([]);
});

/** The /ws messages reach the page as the gateway sends them; `inject` adds one of the test's. */
async function liveStream(page: Page): Promise<{ inject: (message: object) => void }> {
  const routes: WebSocketRoute[] = [];
  await page.routeWebSocket(/\/ws(\?.*)?$/, (ws) => {
    ws.connectToServer(); // everything passes both ways
    routes.push(ws);
  });
  return {
    inject: (message) => {
      for (const ws of routes) ws.send(JSON.stringify([message])); // a frame: an array of messages
    },
  };
}

test("the camera's field of view is drawn up to the walls and the obstacles, not through them", async ({ page }) => {
  const live = await liveStream(page);
  const w = await open(page);
  await gotoAndWait(page, [0.4, 0.6]);
  const [cx, cy] = await pose(page);
  const [xMin, yMin, xMax, yMax] = await arena(page);
  // A field of view as the gateway sends it (near edge left to right, far edge right to left),
  // facing east from the cart, 3 m deep and 5 m wide: beyond the east wall and the south one.
  const fov = (halfNear: number, halfFar: number, reach: number): Point[] => [
    [cx + 0.2, cy + halfNear],
    [cx + 0.2, cy],
    [cx + 0.2, cy - halfNear],
    [cx + reach, cy - halfFar],
    [cx + reach, cy],
    [cx + reach, cy + halfFar],
  ];
  // beyond the east wall, on the view's middle line: nothing is drawn there before, nor after
  const beyond: Point = [(xMax ?? 0) + 0.15, cy];
  const empty = await pixel(page, beyond);
  live.inject({ type: "camera", t: null, fov: fov(0.1, 2.5, 3.0), hits: [] });
  await expect(page.locator("#map")).toHaveAttribute("data-fov", "6");
  await page.waitForTimeout(300); // drawn on the next animation frame
  expect(await pixel(page, beyond)).toEqual(empty);
  await expect.poll(() => fovExtent(page)).toHaveLength(4);
  let [fx0, fy0, fx1, fy1] = await fovExtent(page);
  expect(fx1).toBeLessThanOrEqual((xMax ?? 0) + 0.005);
  expect(fx1).toBeGreaterThan((xMax ?? 0) - 0.05); // up to the wall: the floor before it is seen
  expect(fy0).toBeGreaterThanOrEqual((yMin ?? 0) - 0.005);
  expect(fy0).toBeLessThan((yMin ?? 0) + 0.05); // the south wall cuts the right-hand lines
  expect(fy1).toBeLessThanOrEqual((yMax ?? 0) + 0.005);
  expect(fx0).toBeGreaterThanOrEqual((xMin ?? 0) - 0.005);
  await page.screenshot({ path: `${SHOTS}/fov-walls.png` });

  // an obstacle 0.8 m ahead (its cell 0.7 to 0.9 m): a narrow view ends at its face
  const node: Point = [Math.round((cx + 0.8) * 5) / 5, Math.round(cy * 5) / 5];
  await setObstacle(page, node, true);
  try {
    await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "1");
    live.inject({ type: "camera", t: null, fov: fov(0.02, 0.05, 2.0), hits: [] });
    await expect.poll(async () => (await fovExtent(page))[2] ?? 99).toBeLessThan(node[0] - 0.09);
    [fx0, fy0, fx1, fy1] = await fovExtent(page);
    expect(fx1).toBeGreaterThan(node[0] - 0.11);
  } finally {
    await setObstacle(page, node, false);
  }
  expect(w.pageErrors).toEqual([]);
});

test("Clear obstacles asks first, then takes every obstacle away", async ({ page }) => {
  const w = await open(page);
  const nodes: Point[] = [[0.4, 1.4], [0.8, 1.6], [1.4, 1.2]];
  for (const n of nodes) await setObstacle(page, n, true);
  await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "3");
  const asked: string[] = [];
  page.once("dialog", (d) => {
    asked.push(d.message());
    void d.dismiss(); // no: nothing changes
  });
  await page.click("#clear-obstacles");
  await expect.poll(() => asked).toHaveLength(1);
  expect(asked[0]).toContain("all 3 obstacles");
  await page.waitForTimeout(300);
  expect(await obstacles(page)).toHaveLength(3);
  expect(w.requests).not.toContain("DELETE /api/map/obstacles");
  page.once("dialog", (d) => void d.accept());
  await page.click("#clear-obstacles");
  await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "0");
  expect(await obstacles(page)).toEqual([]);
  await expect(page.locator("#messages")).toContainText("Removed 3 obstacles.");
  expect(w.requests.filter((r) => r === "DELETE /api/map/obstacles")).toHaveLength(1);
  expect(w.pageErrors).toEqual([]);
});

test("a link error's toast goes as soon as the link is up, even while the pointer is on it", async ({ page }) => {
  const w = await open(page);
  const error = "/tmp/cart2d/sim-tty is not open yet";
  await page.route("**/api/status", async (route) => {
    const real = await route.fetch();
    const body = (await real.json()) as { link: Record<string, unknown> };
    body.link = { ...body.link, state: "reconnecting", error };
    await route.fulfill({ response: real, json: body });
  });
  const toast = page.locator("#messages .msg", { hasText: "is not open yet" });
  await expect(toast).toHaveCount(1);
  await toast.hover(); // being read: it would stay until the pointer leaves
  await page.unroute("**/api/status");
  await expect(toast).toHaveCount(0, { timeout: 5000 }); // an error toast's own time is 10 s
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  expect(w.pageErrors).toEqual([]);
});

test("the command form sends WAIT_XY_ARRAY with several points", async ({ page }) => {
  const w = await open(page);
  const [x, y] = await pose(page);
  // three points within the arrival tolerance of where the cart stands: drawn, and nothing moves
  const points: Point[] = [[x + 0.001, y], [x + 0.002, y], [x + 0.003, y]];
  await page.selectOption("#cmd-name", "WAIT_XY_ARRAY");
  await expect(page.locator("#cmd-more")).toBeVisible();
  await expect(page.locator("#cmd-form .args input:enabled")).toHaveCount(3); // n, x0, y0
  await page.click("#cmd-more");
  await page.click("#cmd-more");
  await expect(page.locator("#cmd-form .args input:enabled")).toHaveCount(7);
  await expect(page.locator("#cmd-form input[name=a6]")).toHaveAttribute("placeholder", "y2");
  const fields = [String(points.length), ...points.flat().map((v) => v.toFixed(3))];
  for (const [k, v] of fields.entries()) await page.fill(`#cmd-form input[name=a${k}]`, v);
  const sent = page.waitForRequest((r) => r.method() === "POST" && new URL(r.url()).pathname === "/api/command");
  await page.click("#cmd-form button[type=submit]");
  const body = (await sent).postDataJSON() as { name: string; args: number[] };
  expect(body.name).toBe("WAIT_XY_ARRAY");
  expect(body.args).toEqual(fields.map(Number));
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  await expect(page.locator("#cmd-results")).toContainText("received = 3");
  await expect(page.locator("#map")).toHaveAttribute("data-raw-path", "3");
  // a point with its x and no y is refused in the page
  await page.click("#cmd-more");
  await page.fill("#cmd-form input[name=a7]", "0.5");
  w.requests.length = 0;
  await page.click("#cmd-form button[type=submit]");
  await expect(page.locator("#cmd-msg")).toHaveText("WAIT_XY_ARRAY: point 3 has its x but no y.");
  expect(w.requests).toEqual([]);
  // another command: the form's own four fields again
  await page.selectOption("#cmd-name", "GOTO");
  await expect(page.locator("#cmd-form .args input")).toHaveCount(4);
  await expect(page.locator("#cmd-more")).toBeHidden();
  await page.request.post(`${BASE}/api/stop`, CHANGE);
  expect(w.pageErrors).toEqual([]);
});

test("after Save the badge no longer says the settings are the defaults", async ({ page }) => {
  // a gateway of its own: a blank EEPROM, so the firmware starts on its defaults
  test.setTimeout(90_000);
  const gateway = await startGateway("127.0.0.1", "cart2d-save-badge-");
  try {
    await gateway.waitConnected(60_000);
    await page.goto(`${gateway.base}/`);
    const badge = page.locator('#fw-flags [data-flag="SETTINGS_DEFAULTED"]');
    await expect(badge).toHaveText("default settings (EEPROM)");
    await expect(page.locator("#tune-table")).toHaveAttribute("data-count", /^[1-9]/);
    await page.click("#tune-save");
    await expect(page.locator("#tune-msg")).not.toHaveClass(/form-error/);
    await expect(badge).toHaveCount(0); // the EEPROM holds them now: no reboot needed
    await expect(page.locator("#health")).not.toContainText("default settings");
  } finally {
    await gateway.stop();
  }
});
