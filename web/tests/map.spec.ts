// The map's view in Chromium against the real gateway and simulator (tests/global-setup.ts):
// zoom (wheel, buttons, fit), the cursor's coordinates on hover, set-pose by a drag, a floor plan
// loaded by upload, and a raw path drawn with its warning. The robot is shared: each test leaves
// it stopped at (0, 0, 0) and the map as it found it.

import { expect, test, type Page } from "@playwright/test";

const BASE = process.env["CART2D_URL"] ?? "";

type Point = [number, number];

async function open(page: Page): Promise<string[]> {
  const errors: string[] = [];
  page.on("console", (m) => {
    if (m.type() === "error") errors.push(m.text());
  });
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(`${BASE}/`);
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  await expect(page.locator("#map")).toHaveAttribute("data-scale", /\d/);
  return errors;
}

async function transform(page: Page): Promise<{ ox: number; oy: number; scale: number }> {
  const d = await page.locator("#map").evaluate((c: HTMLElement) => ({ ...c.dataset }));
  return { ox: Number(d["originX"]), oy: Number(d["originY"]), scale: Number(d["scale"]) };
}

async function screenOf(page: Page, p: Point): Promise<Point> {
  const t = await transform(page);
  return [t.ox + p[0] * t.scale, t.oy - p[1] * t.scale];
}

/** Page coordinates of a world point (for page.mouse). */
async function pageOf(page: Page, p: Point): Promise<Point> {
  const box = await page.locator("#map").boundingBox();
  if (!box) throw new Error("no map");
  const [x, y] = await screenOf(page, p);
  return [box.x + x, box.y + y];
}

async function status(page: Page): Promise<{ pose: { x: number; y: number; theta: number } }> {
  return (await page.request.get(`${BASE}/api/status`)).json();
}

test.describe.configure({ mode: "serial" });

test("the wheel zooms about the cursor, the buttons zoom, Fit brings the whole map back", async ({ page }) => {
  const errors = await open(page);
  const fitted = await transform(page);
  await expect(page.locator("#map")).toHaveAttribute("data-fitted", "true");
  // the wheel over the world point (1.0, 0.6): the scale grows, and the point stays under the cursor
  const [mx, my] = await pageOf(page, [1.0, 0.6]);
  await page.mouse.move(mx, my);
  await page.mouse.wheel(0, -400);
  await expect.poll(async () => (await transform(page)).scale).toBeGreaterThan(1.5 * fitted.scale);
  const [ax, ay] = await pageOf(page, [1.0, 0.6]);
  expect(Math.hypot(ax - mx, ay - my)).toBeLessThan(1.5);
  await expect(page.locator("#map")).toHaveAttribute("data-fitted", "false");
  // the buttons: in by 1.5, out by 1.5
  const before = (await transform(page)).scale;
  await page.click("#map-zoom-in");
  await expect.poll(async () => (await transform(page)).scale).toBeCloseTo(before * 1.5, 2);
  await page.click("#map-zoom-out");
  await page.click("#map-zoom-out");
  await expect.poll(async () => (await transform(page)).scale).toBeCloseTo(before / 1.5, 2);
  // a drag pans: the world moves with the pointer
  const t0 = await transform(page);
  const [sx, sy] = await pageOf(page, [0.9, 0.9]);
  await page.mouse.move(sx, sy);
  await page.mouse.down();
  await page.mouse.move(sx + 60, sy + 30, { steps: 5 });
  await page.mouse.up();
  const t1 = await transform(page);
  expect(t1.ox - t0.ox).toBeCloseTo(60, 0);
  expect(t1.oy - t0.oy).toBeCloseTo(30, 0);
  expect(t1.scale).toBe(t0.scale);
  // Fit: the view of the start again
  await page.click("#map-fit");
  const back = await transform(page);
  expect(back.scale).toBeCloseTo(fitted.scale, 3);
  expect(back.ox).toBeCloseTo(fitted.ox, 1);
  expect(back.oy).toBeCloseTo(fitted.oy, 1);
  // the pan did not toggle an obstacle: a drag is not a click
  const map = await (await page.request.get(`${BASE}/api/map`)).json();
  expect(map.obstacles).toEqual([]);
  expect(errors).toEqual([]);
});

test("hovering shows the cursor's coordinates in metres", async ({ page }) => {
  const errors = await open(page);
  for (const p of [[0.0, 0.0], [1.234, 0.567], [-0.1, 1.9]] as Point[]) {
    const [x, y] = await pageOf(page, p);
    await page.mouse.move(x, y);
    const cursor = page.locator("#map-cursor");
    await expect.poll(async () => Number(await cursor.getAttribute("data-x"))).toBeCloseTo(p[0], 2);
    expect(Number(await cursor.getAttribute("data-y"))).toBeCloseTo(p[1], 2);
    await expect(cursor).toContainText(`x ${p[0].toFixed(2)} m`);
    await expect(cursor).toContainText(`y ${p[1].toFixed(2)} m`);
  }
  // zoomed in, the same point reads the same
  await page.click("#map-zoom-in");
  await page.click("#map-zoom-in");
  const [x, y] = await pageOf(page, [0.8, 0.4]);
  await page.mouse.move(x, y);
  await expect.poll(async () => Number(await page.locator("#map-cursor").getAttribute("data-x"))).toBeCloseTo(0.8, 2);
  expect(Number(await page.locator("#map-cursor").getAttribute("data-y"))).toBeCloseTo(0.4, 2);
  await page.mouse.move(1, 1);
  expect(errors).toEqual([]);
});

test("set pose: press where the cart is, drag the way it faces, release", async ({ page }) => {
  const errors = await open(page);
  await page.locator("label", { hasText: "Set pose" }).click();
  await expect(page.locator("#map")).toHaveAttribute("data-mode", "pose");
  const [fx, fy] = await pageOf(page, [0.6, 0.4]);
  const [tx, ty] = await pageOf(page, [0.6, 0.9]); // straight up: +y, 90 degrees
  await page.mouse.move(fx, fy);
  await page.mouse.down();
  await page.mouse.move(tx, ty, { steps: 8 });
  await page.mouse.up();
  await expect
    .poll(async () => {
      const p = (await status(page)).pose;
      return Math.hypot(p.x - 0.6, p.y - 0.4) < 0.01 && Math.abs(p.theta - Math.PI / 2) < 0.05;
    })
    .toBe(true);
  // the map shows it: the odometry readout
  await expect.poll(async () => Number(await page.locator("#pose-x").getAttribute("data-value"))).toBeCloseTo(0.6, 2);
  // a drag down-left: -135 degrees (positions read again: a notice may have moved the page)
  const [hx, hy] = await pageOf(page, [0.6, 0.4]);
  const [gx, gy] = await pageOf(page, [0.3, 0.1]);
  await page.mouse.move(hx, hy);
  await page.mouse.down();
  await page.mouse.move(gx, gy, { steps: 8 });
  await page.mouse.up();
  await expect.poll(async () => (await status(page)).pose.theta).toBeCloseTo((-3 * Math.PI) / 4, 1);
  // no obstacle was set, and the pose goes back to the origin for the other tests
  expect((await (await page.request.get(`${BASE}/api/map`)).json()).obstacles).toEqual([]);
  await page.request.post(`${BASE}/api/pose`, { data: { x: 0, y: 0, theta: 0 }, headers: { Origin: BASE } });
  await page.locator("label", { hasText: "Obstacles" }).click();
  expect(errors).toEqual([]);
});

test("a GOTO sent from the command form is drawn, with a warning that it bypasses the planner", async ({ page }) => {
  const errors = await open(page);
  await expect(page.locator("#map-warning")).toBeHidden();
  await page.selectOption("#cmd-name", "GOTO");
  await page.fill("#cmd-form input[name=a0]", "0"); // where the cart is: drawn, and nothing moves
  await page.fill("#cmd-form input[name=a1]", "0");
  await page.click("#cmd-form button[type=submit]");
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  await expect(page.locator("#map-warning")).toBeVisible();
  await expect(page.locator("#map-warning")).toContainText("GOTO bypasses the planner");
  await expect(page.locator("#map")).toHaveAttribute("data-raw-path", "1");
  expect(errors).toEqual([]);
});

/** A 4 x 4 m room at 0.1 m a cell as a plain PGM: walls round its edge, free inside. */
function roomPgm(): Buffer {
  const pixels = Buffer.alloc(40 * 40, 254);
  for (let k = 0; k < 40; k++) {
    for (const [i, j] of [[k, 0], [k, 39], [0, k], [39, k]] as const) pixels[j * 40 + i] = 0;
  }
  return Buffer.concat([Buffer.from("P5 40 40 255\n"), pixels]);
}

test("a plain floor plan goes where its origin says, and one that leaves the cart off its floor says what to do", async ({ page }) => {
  const errors = await open(page);
  const saved = await (await page.request.get(`${BASE}/api/settings/file`)).body();
  const toasts = page.locator("#messages .msg");
  const load = async (origin: string): Promise<void> => {
    await page.fill("#map-resolution", "0.1");
    await page.fill("#map-origin", origin);
    await page.setInputFiles("#map-file", { name: "room.pgm", mimeType: "image/x-portable-graymap", buffer: roomPgm() });
  };
  // at the default origin the plan's corner is where the cart stands: loaded, with what to do
  await load("0, 0");
  await expect(toasts.filter({ hasText: "Loaded room.pgm" })).toHaveCount(1);
  const warning = toasts.filter({ hasText: "the cart's position (0.000, 0.000) is off the map" });
  await expect(warning).toHaveCount(1);
  await expect(warning).toContainText("Set pose");
  await expect(warning).toContainText("origin");
  // the origin typed in the card: the room round the cart, no warning
  while ((await toasts.count()) > 0) await toasts.first().locator("button").click();
  await load("-2, -2");
  await expect(toasts.filter({ hasText: "Loaded room.pgm" })).toHaveCount(1);
  const map = await (await page.request.get(`${BASE}/api/map`)).json();
  expect(map.floor_plan.origin_m).toEqual([-2, -2]);
  expect(map.arena).toEqual({ x_min: -2, y_min: -2, x_max: 2, y_max: 2 });
  await expect(toasts.filter({ hasText: "off the map" })).toHaveCount(0);
  await expect(toasts.filter({ hasText: "inside a wall" })).toHaveCount(0);
  // an origin that is not two numbers is refused in the page, and nothing is sent
  const version = map.version;
  await load("-2");
  await expect(toasts.filter({ hasText: "x, y in metres" })).toHaveCount(1);
  expect((await (await page.request.get(`${BASE}/api/map`)).json()).version).toBe(version);
  // the map as it was, for the other tests
  const back = await page.request.post(`${BASE}/api/settings/file`, { data: saved, headers: { "Content-Type": "application/json" } });
  expect(back.status()).toBe(200);
  expect(errors).toEqual([]);
});
