// The camera in the panel: a gateway of its own with a test camera (tests/support/mjpeg_server.py, an
// MJPEG server like the ESP32-CAM's) shows the camera's frames through its re-stream; perceived
// cells put on its live map appear on the map and go with "Clear perceived". The shared gateway
// (no camera) says how to give it one instead of a broken image.

import { type ChildProcess } from "node:child_process";

import { expect, test } from "@playwright/test";

import { type Gateway, startGateway, startTestCamera } from "./gateway";

const SHARED = process.env["CART2D_URL"] ?? "";

let camera: ChildProcess | null = null;
let cameraUrl = "";
let gateway: Gateway | null = null;

async function startCamera(): Promise<string> {
  const started = await startTestCamera(["--every-s", "0.1"]);
  camera = started.child;
  return started.url;
}

test.describe.configure({ mode: "serial" });

test.beforeAll(async () => {
  test.setTimeout(60_000);
  cameraUrl = await startCamera();
  gateway = await startGateway("127.0.0.1", "cart2d-camera-", ["--camera-stream", cameraUrl]);
  await gateway.waitConnected();
});

test.afterAll(async () => {
  await gateway?.stop();
  camera?.kill("SIGTERM");
});

test("without a camera the card says how to give the gateway one", async ({ page }) => {
  await page.goto(`${SHARED}/`);
  await expect(page.locator("body")).toHaveAttribute("data-camera", "no");
  await expect(page.locator("#camera-none")).toBeVisible();
  await expect(page.locator("#camera-none")).toContainText("--camera");
  await expect(page.locator("#camera-view")).toBeHidden();
});

test("the camera's frames show, perceived cells appear on the map and clear on the button", async ({ page }) => {
  const base = gateway?.base ?? "";
  const errors: string[] = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(`${base}/`);
  await expect(page.locator("body")).toHaveAttribute("data-camera", "yes");
  const view = page.locator("#camera-view");
  await expect(view).toBeVisible();
  await expect(page.locator("#camera-none")).toBeHidden();
  // frames decoded in the browser: the test camera's 32 x 24 JPEGs
  await expect.poll(() => view.evaluate((img: HTMLImageElement) => img.naturalWidth)).toBe(32);
  await expect(page.locator("#camera-state")).toContainText("fps");

  const cells = [
    [1.0, 0.6, 0.9],
    [1.0, 0.8, 0.6],
    [1.0, 1.0, 1.0],
  ];
  const put = await page.request.put(`${base}/api/perception`, {
    data: { cells, resolution_m: 0.2 },
    headers: { "Content-Type": "application/json" },
  });
  expect(put.status()).toBe(200);
  const map = page.locator("#map");
  await expect(map).toHaveAttribute("data-perceived", "3");
  await expect(map).toHaveAttribute("data-obstacles", "0"); // the user's obstacles are another layer
  await page.locator("#clear-perceived").click();
  await expect(map).toHaveAttribute("data-perceived", "0");
  await expect(page.locator("#perceived-msg")).toContainText("cleared");
  const after = await (await page.request.get(`${base}/api/perception`)).json();
  expect(after.cells).toEqual([]);
  expect(errors).toEqual([]);
});

test("the camera form turns the camera off and on again, and the gateway saves it", async ({ page }) => {
  const base = gateway?.base ?? "";
  await page.goto(`${base}/`);
  const input = page.locator("#camera-url");
  await expect(input).toHaveValue(cameraUrl); // the camera the gateway reads
  await input.fill("");
  await page.locator("#camera-form button[type=submit]").click();
  await expect(page.locator("#camera-msg")).toContainText("no camera");
  await expect(page.locator("body")).toHaveAttribute("data-camera", "no");
  await expect(page.locator("#camera-view")).toBeHidden();
  expect((await (await page.request.get(`${base}/api/settings`)).json()).camera).toEqual({ url: null, stream_url: null });
  await input.fill("ftp://cam");
  await page.locator("#camera-form button[type=submit]").click();
  await expect(page.locator("#camera-msg")).toHaveClass(/form-error/);
  await expect(page.locator("#camera-msg")).toContainText("http://");
  await input.fill(cameraUrl);
  await page.locator("#camera-form button[type=submit]").click();
  await expect(page.locator("#camera-msg")).toContainText("reads this camera now");
  await expect(page.locator("body")).toHaveAttribute("data-camera", "yes");
  const view = page.locator("#camera-view");
  await expect.poll(() => view.evaluate((img: HTMLImageElement) => img.naturalWidth)).toBe(32);
  expect((await (await page.request.get(`${base}/api/settings`)).json()).camera.stream_url).toBe(cameraUrl);
});
