// The API documentation without internet (issue 15): /docs (Swagger UI) and /redoc (ReDoc) in
// Chromium with every request off this machine refused, as on a cart's access point. Their
// scripts come from the gateway (cart2d/server/api_docs.py), not a CDN.

import { expect, type Page, test } from "@playwright/test";

const BASE = process.env["CART2D_URL"] ?? "";

/** Refuses every http(s) request to another host than the gateway's; returns those refused. */
async function offline(page: Page): Promise<string[]> {
  const refused: string[] = [];
  const gateway = new URL(BASE).host;
  await page.context().route("**/*", async (route) => {
    const url = new URL(route.request().url());
    if (url.protocol.startsWith("http") && url.host !== gateway) {
      refused.push(url.href);
      await route.abort("internetdisconnected");
    } else {
      await route.continue();
    }
  });
  return refused;
}

test("Swagger UI at /docs lists the operations with no request off this machine", async ({ page }) => {
  const refused = await offline(page);
  await page.goto(`${BASE}/docs`);
  await expect(page.locator(".swagger-ui .info .title")).toContainText("cart2d gateway");
  await expect(page.locator(".opblock-summary-path", { hasText: "/api/status" }).first()).toBeVisible();
  expect(await page.locator(".opblock").count()).toBeGreaterThan(10);
  expect(refused).toEqual([]);
});

test("ReDoc at /redoc shows the API's title and operations with no request off this machine", async ({ page }) => {
  const refused = await offline(page);
  await page.goto(`${BASE}/redoc`);
  await expect(page.locator("h1").first()).toContainText("cart2d gateway");
  await expect(page.getByText("/api/status", { exact: false }).first()).toBeAttached();
  expect(refused).toEqual([]);
});

test("the panel's API docs link opens Swagger UI", async ({ page }) => {
  const refused = await offline(page);
  await page.goto(`${BASE}/`);
  const [docs] = await Promise.all([page.waitForEvent("popup"), page.click("#api-docs")]);
  await expect(docs.locator(".swagger-ui .info .title")).toContainText("cart2d gateway");
  expect(new URL(docs.url()).pathname).toBe("/docs");
  expect(refused).toEqual([]);
});
