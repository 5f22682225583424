// `cart2d replay` in the panel: a mission's recording played back shows the cart's trail, the
// mission and the plots, says it is a replay, and offers nothing that drives or changes anything.

import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

import { expect, test } from "@playwright/test";

import { type Replay, recordMission, startReplay } from "./replay-helpers";

let dir = "";
let replay: Replay | null = null;
let base = "";

test.beforeAll(async () => {
  dir = mkdtempSync(join(tmpdir(), "cart2d-replay-"));
  const file = recordMission(dir, { obstacles: [[0.4, 0.2]], goals: [[0.8, 0.4]] });
  replay = await startReplay(file, dir, ["--speed", "4"]);
  base = replay.base;
});

test.afterAll(() => {
  replay?.stop();
  rmSync(dir, { recursive: true, force: true });
});

test("a replay shows the recorded mission, says it is a replay and offers no driving", async ({ page }) => {
  const changes: string[] = [];
  page.on("request", (r) => {
    if (r.method() !== "GET") changes.push(`${r.method()} ${new URL(r.url()).pathname}`);
  });
  await page.goto(`${base}/`);
  await expect(page.locator("body")).toHaveAttribute("data-replay", "on");
  await expect(page.locator("#replay-badge")).toContainText("replay of m.mcap");
  for (const control of ["#estop", ".segmented", "#goto-form", "#drive-speed", "#tuning", "#cmd-form"]) {
    await expect(page.locator(control).first()).toBeHidden();
  }
  await expect(page.locator("#map")).toBeVisible();
  await expect(page.locator("#plots")).toBeVisible();
  await expect(page.locator("#truth-pose")).toContainText("x ");
  await expect(page.locator("#replay-badge")).toContainText("(ended)", { timeout: 20_000 });
  await expect(page.locator("#mission-state")).toHaveText("arrived");
  const x = Number(await page.locator("#pose-x").getAttribute("data-value"));
  const y = Number(await page.locator("#pose-y").getAttribute("data-value"));
  expect(Math.hypot(x - 0.8, y - 0.4)).toBeLessThan(0.02); // where the recorded cart arrived
  await page.keyboard.press("ArrowUp");
  await page.keyboard.press("Escape");
  await page.locator("#map").click({ position: { x: 100, y: 100 } });
  await page.waitForTimeout(500);
  expect(changes).toEqual([]);
});
