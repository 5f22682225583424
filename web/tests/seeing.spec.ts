// The cart sees (issue 14, "done when"), as a user of the README's example does: `cart2d camera
// calibrate --sim`, then `cart2d sim --world docs/examples/boxes.json`; the camera card shows the
// simulated camera's frames, the map the boxes and the camera's field of view; a Go-here click at
// (1.6, 0.3), beyond the blue box the map does not know, sends the cart across: the cells the
// camera finds occupied appear on the map, the cart goes round the box (its true pose, from /ws,
// never brings its footprint onto the box, and the simulator counts no box contact) and arrives;
// "Clear perceived" forgets them. A gateway of its own, with the camera on (gateway.ts).

import { spawn } from "node:child_process";
import { copyFileSync } from "node:fs";
import { join } from "node:path";

import { expect, test, type Page } from "@playwright/test";

import { type Gateway, ROOT, startGateway } from "./gateway";
import { type Point, SHOTS } from "./helpers";

const WORLD = join(ROOT, "docs", "examples", "boxes.json");
const GOAL: Point = [1.6, 0.3];
// the blue box of boxes.json: centre (0.9, 0.25), 0.2 x 0.5 m
const BLUE = { x: 0.9, y: 0.25, sx: 0.2, sy: 0.5 };
const BLUE_RGB = [0x30, 0x50, 0xc0];
const PERCEIVED_RGB = [0x93, 0x33, 0xea]; // --map-perceived
const FOV_RGB = [0x08, 0x91, 0xb2]; // --map-fov

let gateway: Gateway | null = null;

/** `cart2d camera calibrate --sim` with the gateway's CART2D_HOME: the calibration it then loads. */
function calibrate(home: string): Promise<void> {
  const cart2d = join(ROOT, "build", "venv", "bin", "cart2d");
  return new Promise((ok, fail) => {
    let output = "";
    const child = spawn(cart2d, ["camera", "calibrate", "--sim"], {
      cwd: ROOT,
      env: { ...process.env, CART2D_HOME: home },
      stdio: ["ignore", "pipe", "pipe"],
    });
    child.stdout?.on("data", (d: Buffer) => (output += d.toString()));
    child.stderr?.on("data", (d: Buffer) => (output += d.toString()));
    child.once("exit", (code) => (code === 0 ? ok() : fail(new Error(`cart2d camera calibrate --sim: ${code}\n${output}`))));
  });
}

test.describe.configure({ mode: "serial" });

test.beforeAll(async () => {
  test.setTimeout(180_000);
  gateway = await startGateway("127.0.0.1", "cart2d-seeing-", ["--world", WORLD], { camera: true, prepare: calibrate });
  await gateway.waitConnected(60_000);
});

test.afterAll(async () => {
  await gateway?.stop();
});

type Transform = { ox: number; oy: number; scale: number };

async function transform(page: Page): Promise<Transform> {
  const d = await page.locator("#map").evaluate((c: HTMLElement) => ({ ...c.dataset }));
  return { ox: Number(d["originX"]), oy: Number(d["originY"]), scale: Number(d["scale"]) };
}

/** The map canvas's pixels at world points; for each, the pixel nearest `rgb` within `reach` CSS
 * pixels (0: the point's own pixel) and its distance to `rgb`. */
async function nearestColour(page: Page, points: Point[], rgb: number[], reach = 0): Promise<number[]> {
  const t = await transform(page);
  const screen = points.map(([x, y]): Point => [t.ox + x * t.scale, t.oy - y * t.scale]);
  return page.locator("#map").evaluate(
    (c: HTMLCanvasElement, [at, want, r]: [Point[], number[], number]) => {
      const dpr = window.devicePixelRatio || 1;
      const ctx = c.getContext("2d");
      if (!ctx) return [];
      return at.map(([px, py]) => {
        let best = Infinity;
        for (let dy = -r; dy <= r; dy++) {
          for (let dx = -r; dx <= r; dx++) {
            const d = ctx.getImageData(Math.round((px + dx) * dpr), Math.round((py + dy) * dpr), 1, 1).data;
            best = Math.min(best, Math.hypot((d[0] ?? 0) - (want[0] ?? 0), (d[1] ?? 0) - (want[1] ?? 0), (d[2] ?? 0) - (want[2] ?? 0)));
          }
        }
        return best;
      });
    },
    [screen, rgb, reach] as [Point[], number[], number],
  );
}

/** How far the cart's centre is from the blue box (0 inside it), m. */
function fromBlue(x: number, y: number): number {
  const dx = Math.max(Math.abs(x - BLUE.x) - BLUE.sx / 2, 0);
  const dy = Math.max(Math.abs(y - BLUE.y) - BLUE.sy / 2, 0);
  return Math.hypot(dx, dy);
}

interface Truth {
  x: number;
  y: number;
  box_contacts: number;
}

interface Perceived {
  cells: [number, number, number][];
}

test("the cart sees the blue box, maps it, drives round it to the goal; Clear perceived forgets it", async ({ page }) => {
  test.setTimeout(240_000);
  const base = gateway?.base ?? "";
  const errors: string[] = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  // what the panel hears on /ws: the simulator's true pose (50 Hz) and the camera's frames
  const truths: Truth[] = [];
  let fov: Point[] = [];
  page.on("websocket", (ws) =>
    ws.on("framereceived", ({ payload }) => {
      // a frame: an array of messages (cart2d/server/live.py)
      for (const msg of JSON.parse(String(payload)) as ({ type?: string } & Record<string, unknown>)[]) {
        if (msg.type === "truth") truths.push(msg as unknown as Truth);
        if (msg.type === "camera" && Array.isArray(msg["fov"])) fov = msg["fov"] as Point[];
      }
    }),
  );
  await page.goto(`${base}/`);
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  const map = page.locator("#map");
  await expect(map).toHaveAttribute("data-scale", /\d/);
  expect((await (await page.request.get(`${base}/api/map`)).json()).obstacles).toEqual([]); // the map does not know the boxes

  // the camera card: the simulated camera's frames, decoded, and not a blank picture
  await expect(page.locator("body")).toHaveAttribute("data-camera", "yes");
  const view = page.locator("#camera-view");
  await expect(view).toBeVisible();
  await expect.poll(() => view.evaluate((img: HTMLImageElement) => img.naturalWidth), { timeout: 30_000 }).toBeGreaterThan(0);
  const spread = await view.evaluate((img: HTMLImageElement) => {
    const c = document.createElement("canvas");
    c.width = img.naturalWidth;
    c.height = img.naturalHeight;
    const ctx = c.getContext("2d");
    if (!ctx) return 0;
    ctx.drawImage(img, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let sum = 0;
    let sq = 0;
    for (let k = 0; k < d.length; k += 4) {
      const v = ((d[k] ?? 0) + (d[k + 1] ?? 0) + (d[k + 2] ?? 0)) / 3;
      sum += v;
      sq += v * v;
    }
    const n = d.length / 4;
    return Math.sqrt(sq / n - (sum / n) ** 2); // the grey level's standard deviation
  });
  expect(spread).toBeGreaterThan(10);
  await expect(page.locator("#camera-state")).toContainText("fps");
  // perception uses the calibration `cart2d camera calibrate --sim` saved, not the nominal model
  const camera = (await (await page.request.get(`${base}/api/camera`)).json()) as { calibration: { calibrated: boolean } };
  expect(camera.calibration.calibrated).toBe(true);

  // the map: the three boxes, the blue one in its colour, and the camera's field of view
  await expect(map).toHaveAttribute("data-boxes", "3");
  // its outline in its colour (drawn over any cells the camera has found there already)
  const outline: Point[] = [[BLUE.x - BLUE.sx / 2, BLUE.y], [BLUE.x + BLUE.sx / 2, BLUE.y], [BLUE.x, BLUE.y + BLUE.sy / 2]];
  for (const d of await nearestColour(page, outline, BLUE_RGB, 2)) expect(d).toBeLessThan(40);
  await expect.poll(async () => Number((await map.getAttribute("data-fov")) ?? "0"), { timeout: 30_000 }).toBeGreaterThanOrEqual(3);
  await expect.poll(() => fov.length).toBeGreaterThanOrEqual(3);
  // its dashed outline: along each edge, most points have the FOV colour within 3 px
  const along: Point[] = [];
  fov.forEach((a, k) => {
    const b = fov[(k + 1) % fov.length] as Point;
    for (const f of [0.2, 0.35, 0.5, 0.65, 0.8]) along.push([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
  });
  const onOutline = (await nearestColour(page, along, FOV_RGB, 3)).filter((d) => d < 40).length;
  expect(onOutline).toBeGreaterThan(0.6 * along.length);

  // Go here, a click at (1.6, 0.3): beyond the blue box, which the map does not know
  await page.locator("label", { hasText: "Go here" }).click();
  await expect(map).toHaveAttribute("data-mode", "goto");
  const t = await transform(page);
  await map.click({ position: { x: t.ox + GOAL[0] * t.scale, y: t.oy - GOAL[1] * t.scale } });
  await expect(page.locator("body")).toHaveAttribute("data-mission", /driving|arrived/);
  const goal = ((await (await page.request.get(`${base}/api/mission`)).json()) as { goal: Point }).goal;
  expect(Math.hypot(goal[0] - GOAL[0], goal[1] - GOAL[1])).toBeLessThan(0.03); // where clicked, snapped to the grid

  // the camera maps the box as the cart drives: perceived cells drawn on the map
  await expect.poll(async () => Number((await map.getAttribute("data-perceived")) ?? "0"), { timeout: 60_000 }).toBeGreaterThan(0);
  await page.screenshot({ path: `${SHOTS}/seeing-driving.png` });
  await expect
    .poll(
      async () => {
        const m = (await (await page.request.get(`${base}/api/mission`)).json()) as { state: string };
        return m.state;
      },
      { timeout: 150_000, intervals: [500] },
    )
    .toBe("arrived");
  await page.waitForTimeout(500); // the last truth and frames reach the page

  // round the box, not through it: the footprint never reached it, and no contact was counted
  const footprint = ((await (await page.request.get(`${base}/api/map`)).json()) as { footprint_radius_m: number }).footprint_radius_m;
  expect(truths.length).toBeGreaterThan(100);
  const closest = Math.min(...truths.map((p) => fromBlue(p.x, p.y)));
  expect(closest).toBeGreaterThan(footprint);
  expect(Math.max(...truths.map((p) => p.box_contacts))).toBe(0);
  const last = truths[truths.length - 1] as Truth;
  expect(Math.hypot(last.x - goal[0], last.y - goal[1])).toBeLessThan(0.05);

  // the perceived cells: on the blue box's side, and drawn in the perceived colour
  const perceived = ((await (await page.request.get(`${base}/api/perception`)).json()) as Perceived).cells;
  const sure = perceived.filter(([, , p]) => p >= 0.9);
  expect(sure.filter(([x, y]) => fromBlue(x, y) < 0.1).length).toBeGreaterThan(0);
  const drawn = await nearestColour(page, sure.map(([x, y]): Point => [x, y]), PERCEIVED_RGB);
  expect(drawn.filter((d) => d < 60).length).toBeGreaterThan(0.6 * sure.length);
  // and the box itself still shows through them: its outline, in its colour, drawn over the cells
  for (const d of await nearestColour(page, outline, BLUE_RGB, 2)) expect(d).toBeLessThan(40);

  // README's picture (docs/images/seeing.png): the map and the camera card at the drive's end
  for (const close of await page.locator("#messages .msg-close").all()) await close.click();
  await page.screenshot({ path: `${SHOTS}/readme-seeing.png` });
  copyFileSync(`${SHOTS}/readme-seeing.png`, `${SHOTS}/seeing-arrived.png`);

  // Clear perceived: the gateway forgets them, the map stops drawing them
  const cleared = page.waitForResponse("**/api/perception/clear");
  await page.locator("#clear-perceived").click();
  expect(((await (await cleared).json()) as Perceived).cells).toEqual([]);
  await expect(page.locator("#perceived-msg")).toContainText("cleared");
  // the camera keeps looking (a wall ahead may be seen again), but the box behind it stays forgotten
  const after = (await (await page.request.get(`${base}/api/perception`)).json()) as Perceived;
  expect(after.cells.filter(([x, y]) => fromBlue(x, y) < 0.3)).toEqual([]);
  // and the map draws what the gateway now holds
  await expect
    .poll(async () => {
      const now = ((await (await page.request.get(`${base}/api/perception`)).json()) as Perceived).cells.length;
      return Number((await map.getAttribute("data-perceived")) ?? "-1") === now;
    })
    .toBe(true);
  expect(errors).toEqual([]);
});
