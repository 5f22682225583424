// The markers of a markers file (`cart2d sim --markers`) and the pose filter's ellipse on the map
// (issue 26): a gateway of its own, no camera: the markers are drawn from the first localisation
// message, and the pose (trusted at the start) with its uncertainty.

import { expect, test } from "@playwright/test";

import { type Gateway, startGateway } from "./gateway";

let gateway: Gateway | null = null;

test.beforeAll(async () => {
  test.setTimeout(60_000);
  gateway = await startGateway("127.0.0.1", "cart2d-markers-", ["--markers", "docs/examples/arena-markers.json"]);
  await gateway.waitConnected();
});

test.afterAll(async () => {
  await gateway?.stop();
});

test("the markers and the localised pose are drawn on the map", async ({ page }) => {
  await page.goto(`${gateway?.base ?? ""}/`);
  const map = page.locator("#map");
  await expect(map).toHaveAttribute("data-markers", "16", { timeout: 20_000 });
  await expect(map).toHaveAttribute("data-localised", "yes");
});

test("Save map says why when the camera has seen nothing", async ({ page }) => {
  await page.goto(`${gateway?.base ?? ""}/`);
  await page.locator("#map-save").click();
  await expect(page.locator("#perceived-msg")).toContainText(/the camera has seen nothing yet/i);
});
