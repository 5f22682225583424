// The plots as a new user reads them (issue 12): the firmware's time in the CSV with an absolute
// timestamp beside it, an export while paused holding only what was shown, one legend per plot
// telling targets from measurements, zoom, and the x–y trajectory against the ground truth.

import { expect, test, type Page } from "@playwright/test";

import { gotoAndWait, open, SHOTS, trustPose } from "./helpers";

test.describe.configure({ mode: "serial" });
test.beforeAll(({ request }) => trustPose(request));

async function exportCsv(page: Page): Promise<string[][]> {
  const [download] = await Promise.all([page.waitForEvent("download"), page.click("#plot-csv")]);
  const text = Buffer.concat(await (await download.createReadStream()).toArray()).toString("utf8");
  return text.trim().split("\n").map((l) => l.split(","));
}

/** Follows the live stream in the page itself: the TICK of the newest telemetry frame. */
async function watchTicks(page: Page): Promise<() => Promise<number>> {
  await page.evaluate(() => {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    ws.addEventListener("message", (e) => {
      // a frame: an array of messages, oldest first (cart2d/server/live.py)
      for (const m of JSON.parse(String(e.data)) as { type: string; tick?: number }[]) {
        if (m.type === "telemetry") (window as unknown as { lastTick: number }).lastTick = m.tick ?? -1;
      }
    });
  });
  await expect.poll(() => page.evaluate(() => (window as unknown as { lastTick?: number }).lastTick ?? -1)).toBeGreaterThan(-1);
  return () => page.evaluate(() => (window as unknown as { lastTick: number }).lastTick);
}

test("the CSV's time is the firmware's (TICK × 8 ms), with the absolute time of each frame beside it", async ({ page }) => {
  const w = await open(page);
  const opened = Date.now();
  await page.waitForTimeout(1500);
  const rows = await exportCsv(page);
  const header = rows[0] ?? [];
  expect(header.slice(0, 2)).toEqual(["t_s", "time_utc"]);
  const [t, when, tick] = ["t_s", "time_utc", "tick"].map((f) => header.indexOf(f));
  const data = rows.slice(1);
  expect(data.length).toBeGreaterThan(20);
  for (let k = 1; k < data.length; k++) {
    const dt = Number(data[k]?.[t ?? 0]) - Number(data[k - 1]?.[t ?? 0]);
    const dticks = (Number(data[k]?.[tick ?? 0]) - Number(data[k - 1]?.[tick ?? 0]) + 65536) % 65536;
    expect(Math.abs(dt - dticks * 0.008)).toBeLessThan(1e-6 + 0.0005); // t_s has 3 decimals
  }
  const times = data.map((r) => Date.parse(r[when ?? 0] ?? ""));
  expect(times.every((ms) => ms >= opened - 60_000 && ms <= Date.now())).toBe(true);
  expect(times.every((ms, k) => k === 0 || ms >= (times[k - 1] ?? 0))).toBe(true);
  expect(w.pageErrors).toEqual([]);
});

test("an export made while paused holds what the plots showed, not what came later", async ({ page }) => {
  await open(page);
  const lastTick = await watchTicks(page);
  await page.waitForTimeout(1500);
  await page.click("#plot-pause");
  const atPause = await lastTick();
  await expect(page.locator("#plot-pause")).toHaveText("Resume");
  await page.waitForTimeout(1500); // ~37 frames arrive meanwhile
  expect((await lastTick()) - atPause).toBeGreaterThan(100);
  const rows = await exportCsv(page);
  const tick = (rows[0] ?? []).indexOf("tick");
  const ticks = rows.slice(1).map((r) => Number(r[tick]));
  expect(ticks.length).toBeGreaterThan(20);
  // one frame may have been on its way as Pause was clicked (5 ticks at 25 Hz)
  expect(Math.max(...ticks)).toBeLessThanOrEqual(atPause + 5);
  await page.click("#plot-pause");
  await expect(page.locator("#plot-pause")).toHaveText("Pause");
});

test("one legend per plot, targets dashed and measurements solid", async ({ page }) => {
  await open(page);
  for (const id of ["#plot-wheels", "#plot-body", "#plot-pwm", "#plot-distance", "#plot-xy"]) {
    await expect(page.locator(`${id} .plot-legend`)).toHaveCount(1);
    await expect(page.locator(`${id} .u-legend`)).toHaveCount(0);
  }
  const wheels = page.locator("#plot-wheels .plot-legend .key");
  await expect(wheels).toHaveText(["left", "left target", "right", "right target"]);
  for (const key of await wheels.all()) {
    const dash = await key.locator("line").getAttribute("stroke-dasharray");
    if ((await key.textContent())?.includes("target")) expect(dash).toBeTruthy();
    else expect(dash).toBeNull();
  }
  // the same colour for a wheel's measurement and its target
  const strokes = await wheels.locator("line").evaluateAll((ls) => ls.map((l) => l.getAttribute("stroke")));
  expect(strokes[0]).toBe(strokes[1]);
  expect(strokes[2]).toBe(strokes[3]);
  expect(strokes[0]).not.toBe(strokes[2]);
});

test("the plots zoom (buttons, Ctrl + wheel), hold the view while zoomed, and follow again on Resume", async ({ page }) => {
  await open(page);
  await page.waitForTimeout(3000);
  const card = page.locator("#plots");
  const span = async (): Promise<number> => Number(await card.getAttribute("data-view-to")) - Number(await card.getAttribute("data-view-from"));
  await expect(card).toHaveAttribute("data-held", "false");
  const live = await span();
  expect(live).toBeGreaterThan(2);
  await page.click("#plot-zoom-in");
  await expect(card).toHaveAttribute("data-held", "true");
  await expect(page.locator("#plot-pause")).toHaveText("Resume");
  // half the span shown when it was clicked (the live span grows with the record until the window is full)
  const zoomed = await span();
  expect(zoomed).toBeGreaterThan(live * 0.45);
  expect(zoomed).toBeLessThan(live * 0.55 + 0.3);
  // held: the view stays while frames arrive
  const from = await card.getAttribute("data-view-from");
  await page.waitForTimeout(800);
  await expect(card).toHaveAttribute("data-view-from", from ?? "");
  // Ctrl + wheel over a plot zooms further in; a plain wheel scrolls the page
  const plot = page.locator("#plot-wheels .u-over");
  await plot.hover();
  const before = await span();
  await page.keyboard.down("Control");
  await page.mouse.wheel(0, -100);
  await page.keyboard.up("Control");
  await expect.poll(span).toBeLessThan(before * 0.9);
  await page.click("#plot-zoom-out");
  await page.click("#plot-pause"); // Resume
  await expect(card).toHaveAttribute("data-held", "false");
  await expect.poll(span).toBeGreaterThan(live * 0.9);
});

test("the x–y trajectory shows the odometry's path against the true pose's", async ({ page }) => {
  const w = await open(page);
  await gotoAndWait(page, [0.4, 0.4]);
  await page.selectOption("#plot-window", "10");
  await gotoAndWait(page, [1.2, 1.2]);
  const xy = page.locator("#plot-xy");
  await expect.poll(async () => Number(await xy.getAttribute("data-odometry-points"))).toBeGreaterThan(30);
  await expect.poll(async () => Number(await xy.getAttribute("data-truth-points"))).toBeGreaterThan(30);
  await expect(page.locator("#plot-xy-note")).toHaveText(/odometry and true pose are \d+ mm apart/);
  // both paths are drawn, in their legend's colours
  const colours = await xy.evaluate((host) => {
    const canvas = host.querySelector("canvas");
    const ctx = canvas?.getContext("2d");
    if (!canvas || !ctx) return { a: 0, b: 0 };
    const data = ctx.getImageData(0, 0, canvas.width, canvas.height).data;
    const rgb = (name: string): number[] => {
      const probe = document.createElement("i");
      probe.style.color = `var(${name})`;
      document.body.append(probe);
      const m = /(\d+), (\d+), (\d+)/.exec(getComputedStyle(probe).color);
      probe.remove();
      return m ? [Number(m[1]), Number(m[2]), Number(m[3])] : [];
    };
    const count = (c: number[]): number => {
      let n = 0;
      for (let i = 0; i < data.length; i += 4) {
        if (Math.abs((data[i] ?? 0) - (c[0] ?? 0)) < 12 && Math.abs((data[i + 1] ?? 0) - (c[1] ?? 0)) < 12 && Math.abs((data[i + 2] ?? 0) - (c[2] ?? 0)) < 12) n++;
      }
      return n;
    };
    return { a: count(rgb("--plot-a")), b: count(rgb("--plot-b")) };
  });
  expect(colours.a).toBeGreaterThan(100);
  expect(colours.b).toBeGreaterThan(100);
  await page.selectOption("#plot-window", "20");
  await page.locator(".plots-card").screenshot({ path: `${SHOTS}/plots-trajectory.png` });
  expect(w.pageErrors).toEqual([]);
});
