// "Explore" (issue 26): in the simulator with its camera on and boxes the map does not show, the
// button starts exploration; its progress shows (the floor seen grows, frontiers, time) and the
// button waits while the cart explores; STOP ends it with the sentence and the map saved. A
// gateway of its own, with the camera on (gateway.ts).

import { join } from "node:path";

import { expect, test } from "@playwright/test";

import { type Gateway, ROOT, startGateway } from "./gateway";
import { SHOTS } from "./helpers";

let gateway: Gateway | null = null;

test.beforeAll(async () => {
  test.setTimeout(120_000);
  const world = join(ROOT, "docs", "examples", "boxes.json");
  gateway = await startGateway("127.0.0.1", "cart2d-explore-", ["--world", world], { camera: true });
  await gateway.waitConnected(60_000);
});

test.afterAll(async () => {
  await gateway?.stop();
});

test("Explore shows its progress, and STOP ends it with the map saved", async ({ page }) => {
  test.setTimeout(120_000);
  await page.goto(`${gateway?.base ?? ""}/`);
  await page.locator("#map-save-name").fill("explored-room");
  const msg = page.locator("#explore-msg");
  const button = page.locator("#explore");
  // the camera's first frame may still be on its way: the gateway says so, and a second press starts it
  await expect(async () => {
    await button.click();
    await expect(msg).toContainText(/^Exploring: /, { timeout: 3_000 });
  }).toPass({ timeout: 40_000 });
  await expect(button).toBeDisabled();
  await expect(msg).toContainText(/(?!0\.0 )\d+\.\d m² seen \(\d+ %\), \d+ frontiers.*\d+ goals, \d+ s/, { timeout: 30_000 });
  await page.screenshot({ path: `${SHOTS}/explore-progress.png` });
  await page.locator("#estop").click();
  await expect(msg).toContainText(/^exploration stopped by the user; map saved as \S+explored-room\.yaml/, {
    timeout: 20_000,
  });
  await expect(button).toBeEnabled();
});
