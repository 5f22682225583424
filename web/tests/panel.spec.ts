// The panel in Chromium against a real gateway and simulator (tests/global-setup.ts). The
// robot is shared: the tests run in order, each leaving it stopped.

import { mkdirSync } from "node:fs";
import { resolve } from "node:path";
import { expect, test, type Page } from "@playwright/test";

const BASE = process.env["CART2D_URL"] ?? "";
const SHOTS = resolve(import.meta.dirname, "..", "..", "build", "screenshots");
mkdirSync(SHOTS, { recursive: true });

type Point = [number, number];

interface Watched {
  consoleErrors: string[];
  pageErrors: string[];
  requests: string[];
}

async function open(page: Page): Promise<Watched> {
  const watched: Watched = { consoleErrors: [], pageErrors: [], requests: [] };
  page.on("console", (m) => {
    if (m.type() === "error") watched.consoleErrors.push(m.text());
  });
  page.on("pageerror", (e) => watched.pageErrors.push(String(e)));
  page.on("request", (r) => {
    if (r.method() !== "GET") watched.requests.push(`${r.method()} ${new URL(r.url()).pathname}`);
  });
  await page.goto(`${BASE}/`);
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  await expect(page.locator("#pose-x")).toHaveAttribute("data-value", /\d/);
  await expect(page.locator("#map")).toHaveAttribute("data-scale", /\d/);
  return watched;
}

/** The map's CSS-pixel position of world point p, from the transform the canvas publishes. */
async function screenOf(page: Page, p: Point): Promise<Point> {
  const d = await page.locator("#map").evaluate((c: HTMLElement) => ({ ...c.dataset }));
  const scale = Number(d["scale"]);
  return [Number(d["originX"]) + p[0] * scale, Number(d["originY"]) - p[1] * scale];
}

async function pixel(page: Page, p: Point): Promise<number[]> {
  const [x, y] = await screenOf(page, p);
  return page.locator("#map").evaluate(
    (c: HTMLCanvasElement, [px, py]: Point) => {
      const dpr = window.devicePixelRatio || 1;
      const ctx = c.getContext("2d");
      return ctx ? Array.from(ctx.getImageData(Math.round(px * dpr), Math.round(py * dpr), 1, 1).data) : [];
    },
    [x, y] as Point,
  );
}

async function clickMap(page: Page, p: Point): Promise<void> {
  const [x, y] = await screenOf(page, p);
  await page.locator("#map").click({ position: { x, y } });
}

async function pose(page: Page): Promise<Point> {
  const x = Number(await page.locator("#pose-x").getAttribute("data-value"));
  const y = Number(await page.locator("#pose-y").getAttribute("data-value"));
  return [x, y];
}

async function obstacles(page: Page): Promise<Point[]> {
  const r = await page.request.get(`${BASE}/api/map`);
  return ((await r.json()) as { obstacles: Point[] }).obstacles;
}

const near = (a: Point, b: Point, tol = 1e-6): boolean => Math.hypot(a[0] - b[0], a[1] - b[1]) <= tol;

async function driveAway(page: Page, to: Point): Promise<void> {
  await page.fill("#goto-form input[name=x]", String(to[0]));
  await page.fill("#goto-form input[name=y]", String(to[1]));
  await page.click("#goto-form button[type=submit]");
  await expect(page.locator("body")).toHaveAttribute("data-mission", "driving");
  // moving: the odometry readout changes
  const start = await pose(page);
  await expect.poll(async () => Math.hypot(...((await pose(page)).map((v, k) => v - (start[k] ?? 0)) as Point))).toBeGreaterThan(0.05);
}

async function expectHalted(page: Page): Promise<void> {
  await expect(page.locator("body")).toHaveAttribute("data-mission", "failed");
  await expect(page.locator("#mission-detail")).toContainText("stopped by the user");
  await page.waitForTimeout(400); // the last of the braking
  const a = await pose(page);
  await page.waitForTimeout(1000);
  const b = await pose(page);
  expect(Math.hypot(a[0] - b[0], a[1] - b[1])).toBeLessThan(0.003);
  const status = await (await page.request.get(`${BASE}/api/status`)).json();
  expect(status.status.mode).not.toBe("PATH");
}

test.describe.configure({ mode: "serial" });

test("the page loads with no console errors and shows the status", async ({ page }) => {
  const w = await open(page);
  await expect(page.locator("#fw-version")).toContainText("0.1.0");
  await expect(page.locator("#link-port")).toHaveText("simulator");
  await expect(page.locator("#mission-state")).toHaveText("idle");
  await expect(page.locator("#cpu-load")).toContainText("%");
  await expect(page.locator("#overruns")).toHaveText(/^\d+$/);
  await expect(page.locator("#truth-row")).toBeVisible(); // simulation: the true pose beside
  await expect(page.locator("#cmd-name option")).not.toHaveCount(0);
  await page.waitForTimeout(500);
  expect(w.consoleErrors).toEqual([]);
  expect(w.pageErrors).toEqual([]);
  expect(w.requests).toEqual([]); // loading changes nothing
});

test("the generic command POSE shows its reply", async ({ page }) => {
  const w = await open(page);
  await page.selectOption("#cmd-name", "POSE");
  await page.click("#cmd-form button[type=submit]");
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  await expect(page.locator("#cmd-results")).toContainText("x = ");
  await expect(page.locator("#cmd-results")).toContainText("theta = ");
  await expect(page.locator("#cmd-message")).toHaveText("–");
  expect(w.requests).toEqual(["POST /api/command"]);
  // a command the firmware refuses: its reply's message is shown
  await page.selectOption("#cmd-name", "TOL_SET");
  await page.fill("#cmd-form input[name=a0]", "7");
  await page.click("#cmd-form button[type=submit]");
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_ERROR");
  await expect(page.locator("#cmd-message")).not.toHaveText("–");
  await page.locator("#cmd-form").screenshot({ path: `${SHOTS}/command.png` });
  expect(w.pageErrors).toEqual([]);
});

test("bad inputs are refused in the page with a message and send nothing", async ({ page }) => {
  const w = await open(page);
  await page.selectOption("#cmd-name", "GOTO");
  const cases: [string, string, RegExp][] = [
    ["", "", /empty/],
    ["abc", "1", /not a number/],
    ["NaN", "1", /not a number/],
    ["1", "Infinity", /not a number/],
    ["1e9", "0", /out of range/],
    ["0.5", "", /empty/],
  ];
  for (const [a, b, message] of cases) {
    await page.fill("#cmd-form input[name=a0]", a);
    await page.fill("#cmd-form input[name=a1]", b);
    await page.click("#cmd-form button[type=submit]");
    await expect(page.locator("#cmd-msg")).toHaveText(message);
    await expect(page.locator("#cmd-msg")).toHaveClass(/form-error/);
  }
  for (const [x, y, message] of [["", "0.4", /x is empty/], ["0.4", "1,2,3", /y is not a number/]] as const) {
    await page.fill("#goto-form input[name=x]", x);
    await page.fill("#goto-form input[name=y]", y);
    await page.click("#goto-form button[type=submit]");
    await expect(page.locator("#goto-msg")).toHaveText(message);
  }
  await page.waitForTimeout(300);
  expect(w.requests).toEqual([]);
  await expect(page.locator("#mission-state")).toHaveText("idle");

  // the gateway's 4xx sentence is shown: a goal off the map
  await page.fill("#goto-form input[name=x]", "5");
  await page.fill("#goto-form input[name=y]", "5");
  await page.click("#goto-form button[type=submit]");
  await expect(page.locator("#goto-msg")).toContainText("off the map");
  await expect(page.locator("#messages")).toContainText("The goal (5.000, 5.000) is off the map");
  await expect(page.locator("#mission-state")).toHaveText("idle");
  await page.screenshot({ path: `${SHOTS}/error-message.png` });
  expect(w.pageErrors).toEqual([]);
});

test("toggling an obstacle on the map changes the map and its drawing", async ({ page }) => {
  await open(page);
  const node: Point = [0.4, 0.8];
  expect((await obstacles(page)).some((o) => near(o, node))).toBe(false);
  await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "0");
  const before = await pixel(page, node);

  await clickMap(page, node);
  await expect.poll(async () => (await obstacles(page)).some((o) => near(o, node))).toBe(true);
  await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "1");
  await expect.poll(() => pixel(page, node)).not.toEqual(before);
  const drawn = await pixel(page, node);
  await page.locator(".map-card").screenshot({ path: `${SHOTS}/map-obstacle.png` });

  await clickMap(page, node);
  await expect.poll(async () => (await obstacles(page)).length).toBe(0);
  await expect(page.locator("#map")).toHaveAttribute("data-obstacles", "0");
  await expect.poll(() => pixel(page, node)).not.toEqual(drawn);
});

test("a click in Go-here mode sends the robot around an obstacle to the point", async ({ page }) => {
  const w = await open(page);
  const blocker: Point = [0.4, 0.4];
  const goal: Point = [0.8, 0.8];
  await clickMap(page, blocker);
  await expect.poll(async () => (await obstacles(page)).length).toBe(1);

  await page.locator("label", { hasText: "Go here" }).click();
  await expect(page.locator("#map")).toHaveAttribute("data-mode", "goto");
  await clickMap(page, goal);
  await expect(page.locator("body")).toHaveAttribute("data-mission", "driving");
  const mission = await (await page.request.get(`${BASE}/api/mission`)).json();
  const path = mission.plan.grid_path as Point[];
  expect(path.some((p) => near(p, blocker, 0.01))).toBe(false); // the planned path avoids it
  await page.waitForTimeout(700);
  await page.screenshot({ path: `${SHOTS}/driving-desktop.png` });

  await expect(page.locator("body")).toHaveAttribute("data-mission", "arrived", { timeout: 20_000 });
  await expect.poll(async () => Math.hypot((await pose(page))[0] - goal[0], (await pose(page))[1] - goal[1])).toBeLessThan(0.02);
  await expect(page.locator("#mission-detail")).toContainText("arrived");
  await page.screenshot({ path: `${SHOTS}/arrived-desktop.png`, fullPage: true });

  // clean up: obstacle mode, remove the blocker
  await page.locator("label", { hasText: "Obstacles" }).click();
  await clickMap(page, blocker);
  await expect.poll(async () => (await obstacles(page)).length).toBe(0);
  expect(w.requests.filter((r) => r === "POST /api/goto")).toHaveLength(1);
  expect(w.pageErrors).toEqual([]);
});

test("the emergency stop button and the Escape key halt a moving robot", async ({ page }) => {
  await open(page);
  await driveAway(page, [1.6, 0.2]);
  await page.click("#estop");
  await expectHalted(page);

  await driveAway(page, [0.2, 1.4]);
  await page.keyboard.press("Escape");
  await expectHalted(page);
});

test("holding an arrow key drives the robot; releasing it stops", async ({ page }) => {
  const w = await open(page);
  const start = await pose(page);
  await page.locator("#map").click({ position: { x: 2, y: 2 } }); // focus the page, not a field
  w.requests.length = 0;
  await page.keyboard.down("ArrowUp");
  await page.waitForTimeout(1200);
  await page.keyboard.up("ArrowUp");
  await page.waitForTimeout(800);
  const end = await pose(page);
  expect(Math.hypot(end[0] - start[0], end[1] - start[1])).toBeGreaterThan(0.1);
  const drives = w.requests.filter((r) => r === "POST /api/drive").length;
  expect(drives).toBeGreaterThanOrEqual(6); // repeated every 150 ms while held
  const a = await pose(page);
  await page.waitForTimeout(600);
  const b = await pose(page);
  expect(Math.hypot(a[0] - b[0], a[1] - b[1])).toBeLessThan(0.003);
  expect(w.pageErrors).toEqual([]);
});

test("the layout works at a phone's width", async ({ browser }) => {
  const context = await browser.newContext({ viewport: { width: 390, height: 844 }, deviceScaleFactor: 2, hasTouch: true });
  const page = await context.newPage();
  const w = await open(page);
  const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
  expect(overflow).toBeLessThanOrEqual(0);
  const estop = page.locator("#estop");
  await expect(estop).toBeInViewport({ ratio: 1 });
  const box = await estop.boundingBox();
  expect(box && box.width >= 44 && box.height >= 44).toBe(true);
  for (const id of ["#map", "#cmd-form", "#plot-body"]) {
    const b = await page.locator(id).boundingBox();
    expect(b && b.x >= 0 && b.x + b.width <= 390.5).toBe(true);
  }
  await page.screenshot({ path: `${SHOTS}/phone.png` });
  await page.screenshot({ path: `${SHOTS}/phone-full.png`, fullPage: true });
  await page.evaluate(() => window.scrollTo(0, document.body.scrollHeight));
  await expect(estop).toBeInViewport({ ratio: 1 }); // still there at the bottom of the page
  await page.screenshot({ path: `${SHOTS}/phone-scrolled.png` });
  expect(w.consoleErrors).toEqual([]);
  expect(w.pageErrors).toEqual([]);
  await context.close();
});
