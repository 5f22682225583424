// The simulated world's boxes from the panel (issue 14): in simulation the map has a "Box" mode, a
// legend entry and a "Clear boxes" button; a click in Box mode drops a 0.2 × 0.2 m box that the
// simulator then holds (GET /api/sim/world) and the map draws in the box's colour, a click on it
// takes it away, and boxes added elsewhere (the API) reach the map through /ws "sim_world".

import { expect, test, type APIRequestContext, type Page } from "@playwright/test";

import { BASE, clickMap, open, pixel, pose, type Point, SHOTS } from "./helpers";

test.describe.configure({ mode: "serial" });

interface Box {
  id: string;
  x: number;
  y: number;
  sx: number;
  sy: number;
  height: number;
  colour: string;
}

const JSON_TYPE = { "Content-Type": "application/json" };

async function worldBoxes(request: APIRequestContext): Promise<Box[]> {
  const r = await request.get(`${BASE}/api/sim/world`);
  expect(r.ok(), await r.text()).toBe(true);
  return ((await r.json()) as { boxes: Box[] }).boxes;
}

async function clearBoxes(request: APIRequestContext): Promise<void> {
  const r = await request.delete(`${BASE}/api/sim/boxes`, { headers: JSON_TYPE });
  expect(r.ok(), await r.text()).toBe(true);
}

/** Of the arena's free corners, the one farthest from the cart (a box may not go under it). */
async function awayFromCart(page: Page): Promise<Point> {
  const at = await pose(page);
  const corners: Point[] = [[1.4, 1.4], [0.4, 1.4], [1.4, 0.4], [0.4, 0.4]];
  const distance = (p: Point): number => Math.hypot(p[0] - at[0], p[1] - at[1]);
  return corners.reduce((best, p) => (distance(p) > distance(best) ? p : best));
}

test.beforeAll(async ({ request }) => clearBoxes(request));
test.afterAll(async ({ request }) => clearBoxes(request));

test("a click in Box mode drops a box the simulator holds and the map draws; a click takes it away", async ({ page }) => {
  const watched = await open(page);
  await expect(page.locator("#map-mode-box")).toBeVisible();
  await expect(page.locator("#legend-box")).toBeVisible();
  await expect(page.locator("#sim-world")).toBeVisible();
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "0");

  const at = await awayFromCart(page);
  const floor = await pixel(page, at);
  await page.locator("#map-mode-box").click();
  await expect(page.locator("#map")).toHaveAttribute("data-mode", "box");
  await clickMap(page, at);
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "1");

  const boxes = await worldBoxes(page.request);
  expect(boxes).toHaveLength(1);
  const box = boxes[0] as Box;
  expect(Math.hypot(box.x - at[0], box.y - at[1])).toBeLessThan(0.01); // where clicked
  expect([box.sx, box.sy, box.height, box.colour]).toEqual([0.2, 0.2, 0.3, "#b8742f"]);
  await expect(page.locator("#sim-world-msg")).toHaveText("1 box stands in the world.");

  // drawn in its colour (#b8742f: more red than blue) where the floor was drawn before; the
  // pixel 5 cm in from its corner, clear of the crate's cross
  const inside: Point = [at[0] + 0.05, at[1] + 0.0];
  await expect.poll(async () => {
    const [r = 0, , b = 0] = await pixel(page, inside);
    return r - b;
  }).toBeGreaterThan(40);
  expect(floor).not.toEqual(await pixel(page, inside));
  await page.locator(".map-card").screenshot({ path: `${SHOTS}/sim-world-box.png` });

  // a click on the box takes it away, from the world and the map
  await clickMap(page, [at[0] - 0.05, at[1] + 0.05]);
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "0");
  expect(await worldBoxes(page.request)).toEqual([]);
  expect(watched.pageErrors).toEqual([]);
  expect(watched.requests).toEqual(["POST /api/sim/boxes", `DELETE /api/sim/boxes/${box.id}`]);
});

test("boxes added through the API reach the map; Clear boxes takes them all away", async ({ page }) => {
  await open(page);
  const at = await awayFromCart(page);
  const r = await page.request.post(`${BASE}/api/sim/boxes`, {
    data: { boxes: [{ x: at[0], y: at[1], sx: 0.3, sy: 0.1, colour: "#2a6fdb" }, { x: 0.9, y: 0.9, sx: 0.1, sy: 0.1 }] },
  });
  expect(r.ok(), await r.text()).toBe(true);
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "2"); // told on /ws
  await expect.poll(async () => {
    const [red = 0, , blue = 0] = await pixel(page, [at[0] + 0.1, at[1]]);
    return blue - red; // #2a6fdb: more blue than red
  }).toBeGreaterThan(40);
  await page.getByRole("button", { name: "Clear boxes" }).click();
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "0");
  await expect(page.locator("#sim-world-msg")).toHaveText("0 boxes stand in the world.");
  expect(await worldBoxes(page.request)).toEqual([]);
});

test("boxes standing before the page opens are drawn at once", async ({ page }) => {
  const r = await page.request.post(`${BASE}/api/sim/boxes`, { data: { boxes: [{ x: 0.9, y: 1.5, sx: 0.2, sy: 0.2, id: "early" }] } });
  expect(r.ok(), await r.text()).toBe(true);
  await open(page);
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "1");
  await clearBoxes(page.request);
  await expect(page.locator("#map")).toHaveAttribute("data-boxes", "0"); // told on /ws
});

test("on a real cart (GET answers 404) the Box mode, its legend and Clear boxes stay hidden", async ({ page }) => {
  await page.route("**/api/sim/world", (route) =>
    route.fulfill({ status: 404, contentType: "application/json", body: JSON.stringify({ detail: "there is no simulator" }) }),
  );
  const asked = page.waitForResponse("**/api/sim/world");
  const w = await open(page);
  expect((await asked).status()).toBe(404);
  await expect(page.locator("#sim-world")).toHaveAttribute("data-loaded", "true");
  for (const id of ["#sim-world", "#map-mode-box", "#legend-box"]) await expect(page.locator(id)).toBeHidden();
  await expect(page.locator("#messages")).not.toContainText("simulator");
  expect(w.pageErrors).toEqual([]);
});
