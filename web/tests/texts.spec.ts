// Small texts of the panel built from the gateway's answers (issue 12: "1 waypoints"), in
// Chromium against the shared gateway and simulator (tests/global-setup.ts). Runs after
// panel.spec.ts and leaves the robot stopped, as every test does.

import { expect, test } from "@playwright/test";

const BASE = process.env["CART2D_URL"] ?? "";

type Point = [number, number];

test("a go-to in a straight line says 1 waypoint, not 1 waypoints", async ({ page }) => {
  await page.goto(`${BASE}/`);
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  // Whatever the tests before left: a trusted pose and a map without obstacles.
  expect((await page.request.post(`${BASE}/api/pose/accept`, { data: {} })).ok()).toBe(true);
  const map = (await (await page.request.get(`${BASE}/api/map`)).json()) as { obstacles: Point[] };
  for (const [x, y] of map.obstacles) {
    expect((await page.request.put(`${BASE}/api/map/obstacle`, { data: { x, y, present: false } })).ok()).toBe(true);
  }
  const status = (await (await page.request.get(`${BASE}/api/status`)).json()) as { pose: { x: number; y: number } };
  const inside = (v: number): number => Math.min(Math.max(v, 0.4), 1.4);
  const x = inside(status.pose.x);
  const goal: Point = [x < 0.9 ? x + 0.4 : x - 0.4, inside(status.pose.y)];

  await page.fill("#goto-form input[name=x]", goal[0].toFixed(2));
  await page.fill("#goto-form input[name=y]", goal[1].toFixed(2));
  await page.click("#goto-form button[type=submit]");
  await expect(page.locator("#goto-msg")).toHaveText(/^Driving to \(.+\): \d+\.\d\d m, 1 waypoint\.$/);
  await expect(page.locator("body")).toHaveAttribute("data-mission", "arrived", { timeout: 20_000 });
});
