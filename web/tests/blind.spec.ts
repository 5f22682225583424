// The camera is never silently blind (issue 22): a gateway of its own reads a test camera
// (tests/support/mjpeg_server.py, QVGA frames perception takes in); the camera card says it sees. Mid-
// mission the camera stalls (SIGSTOP: its connection stays open, nothing comes): the gateway stops
// the cart, a toast says the camera went blind, the mission failed with that reason, the card
// says blind in red and why; once the camera sends again the card says it sees.

import { type ChildProcess } from "node:child_process";

import { expect, test } from "@playwright/test";

import { type Gateway, startGateway, startTestCamera } from "./gateway";

let camera: ChildProcess | null = null;
let gateway: Gateway | null = null;

async function startCamera(): Promise<string> {
  const started = await startTestCamera(["--every-s", "0.066", "--width", "320", "--height", "240"]);
  camera = started.child;
  return started.url;
}

test.describe.configure({ mode: "serial" });

test.beforeAll(async () => {
  test.setTimeout(60_000);
  const url = await startCamera();
  gateway = await startGateway("127.0.0.1", "cart2d-blind-", ["--camera-stream", url]);
  await gateway.waitConnected();
});

test.afterAll(async () => {
  camera?.kill("SIGCONT");
  await gateway?.stop();
  camera?.kill("SIGTERM");
});

interface Truth {
  t: number;
  v: number;
}

test("the camera stalling mid-mission stops the cart, and the panel says it went blind", async ({ page }) => {
  test.setTimeout(120_000);
  const base = gateway?.base ?? "";
  const errors: string[] = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  const truths: Truth[] = [];
  page.on("websocket", (ws) =>
    ws.on("framereceived", ({ payload }) => {
      // a frame: an array of messages (cart2d/server/live.py)
      for (const msg of JSON.parse(String(payload)) as ({ type?: string } & Record<string, unknown>)[]) {
        if (msg.type === "truth") truths.push(msg as unknown as Truth);
      }
    }),
  );
  await page.goto(`${base}/`);
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  await expect(page.locator("body")).toHaveAttribute("data-camera-sees", "yes", { timeout: 20_000 });
  const state = page.locator("#camera-state");
  await expect(state).toContainText("fps");
  await expect(state).not.toHaveClass(/form-error/);

  // across the default map: 1.8 m ahead, seconds of driving at 0.5 m/s
  const goto = await page.request.post(`${base}/api/goto`, { data: { x: 1.8, y: 0.0 } });
  expect(goto.status(), await goto.text()).toBe(200);
  await expect(page.locator("body")).toHaveAttribute("data-mission", "driving");
  await expect.poll(() => truths.filter((m) => Math.abs(m.v) > 0.1).length, { timeout: 20_000 }).toBeGreaterThan(0);
  camera?.kill("SIGSTOP"); // the camera stalls: its stream stays open, nothing comes
  const stalled = truths[truths.length - 1] as Truth;

  const toast = page.locator("#messages .msg", { hasText: "camera went blind" });
  await expect(toast).toBeVisible({ timeout: 20_000 });
  await expect(toast).toContainText("The mission failed: the camera went blind: no frame taken in for");
  await expect(page.locator("body")).toHaveAttribute("data-mission", "failed");
  const mission = (await (await page.request.get(`${base}/api/mission`)).json()) as { state: string; reason: string };
  expect(mission.reason).toMatch(/^the camera went blind: no frame taken in for \d+\.\d s \(/);

  // the card: blind, in red, and why
  await expect(page.locator("body")).toHaveAttribute("data-camera-sees", "no", { timeout: 10_000 });
  await expect(state).toContainText("blind: ");
  await expect(state).toHaveClass(/form-error/);

  // the simulated cart stopped (ground truth), in simulated time soon after the camera stalled
  await expect.poll(() => Math.abs(truths[truths.length - 1]?.v ?? 1), { timeout: 10_000 }).toBeLessThan(0.005);
  const moving = truths.filter((m) => m.t >= stalled.t && Math.abs(m.v) >= 0.005);
  expect(Math.max(...moving.map((m) => m.t)) - stalled.t).toBeLessThan(2.5);

  // the camera sends again: the card says it sees
  camera?.kill("SIGCONT");
  await expect(page.locator("body")).toHaveAttribute("data-camera-sees", "yes", { timeout: 30_000 });
  await expect(state).not.toHaveClass(/form-error/);
  expect(errors).toEqual([]);
});
