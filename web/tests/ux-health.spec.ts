// Health a new user can see (issue 12): the firmware's STATUS flags as readable badges, live
// values that say they are stale when telemetry stops, and a step response that refuses to be a
// tuning result when it could not measure one.

import { expect, test, type Page } from "@playwright/test";

import { BASE, command, faceEastWall, gotoAndWait, open, pose, SHOTS, trustPose, type Point } from "./helpers";

test.describe.configure({ mode: "serial" });
test.beforeAll(({ request }) => trustPose(request));

const TELEMETRY_HZ = 25; // the firmware's default (config/robot.toml)

async function telemetry(page: Page, hz: number): Promise<void> {
  // the panel has seen telemetry arrive first (before the first frame it says it has none)
  if (hz === 0) await expect(page.locator("body")).toHaveAttribute("data-telemetry", "live");
  expect((await command(page, "TELEMETRY", [hz])).status).toBe("CONTROL_OK");
}

async function flags(page: Page): Promise<string[]> {
  return ((await (await page.request.get(`${BASE}/api/status`)).json()) as { status: { flags: string[] } }).status.flags;
}

test("a cart pushing a wall shows its flags as badges (bumper, switches), each explained on a tap", async ({ page }) => {
  const w = await open(page);
  // every badge the top bar shows, with its words, as it shows them
  await page.evaluate(() => {
    const seen: Record<string, string> = {};
    (window as unknown as { seen: Record<string, string> }).seen = seen;
    const bar = document.getElementById("fw-flags");
    if (!bar) return;
    new MutationObserver(() => {
      for (const b of bar.querySelectorAll<HTMLElement>("[data-flag]")) seen[b.dataset["flag"] ?? ""] = b.textContent ?? "";
    }).observe(bar, { childList: true, subtree: true });
  });
  const seen = (): Promise<Record<string, string>> => page.evaluate(() => (window as unknown as { seen: Record<string, string> }).seen);
  await faceEastWall(page, 0.28);
  await page.locator("#drive-title").click(); // the page has the keyboard, not a field
  await page.keyboard.down("ArrowUp");
  // The firmware stops the cart and raises BUMPER; the panel's next (refused) drive ends the key's
  // driving, and its stop, a VELOCITY of 0, clears BUMPER again while the switches stay closed.
  await expect.poll(async () => (await seen())["BUMPER"], { timeout: 5000 }).toBe("bumper hit");
  await page.keyboard.up("ArrowUp");

  const bar = page.locator("#fw-flags");
  await expect(bar.locator('[data-flag="SWITCH_LEFT"]')).toHaveText("left switch pressed");
  await expect(bar.locator('[data-flag="SWITCH_RIGHT"]')).toHaveText("right switch pressed");
  await expect(page.locator('#health [data-flag="SWITCH_LEFT"]')).toBeVisible(); // every flag, in the map card
  // /api/status: the STATUS the gateway last read (a few times a second)
  await expect.poll(() => flags(page)).toEqual(expect.arrayContaining(["SWITCH_LEFT", "SWITCH_RIGHT"]));
  // a tap (a click) says what the flag means, in the protocol's words
  await bar.locator('[data-flag="SWITCH_LEFT"]').click();
  await expect(page.locator("#messages")).toContainText("left switch pressed (SWITCH_LEFT): left front switch pressed.");
  await page.locator("header").screenshot({ path: `${SHOTS}/flags.png` });

  // back away (allowed with a switch closed), then drive off: the badges go
  await page.keyboard.down("ArrowDown");
  await page.waitForTimeout(700);
  await page.keyboard.up("ArrowDown");
  await page.waitForTimeout(600); // the panel's last drive, a stop, is sent before the goal
  await gotoAndWait(page, [1.2, 0.8]);
  await expect(bar.locator('[data-flag="SWITCH_LEFT"]')).toHaveCount(0);
  await expect(page.locator('#health [data-flag="ARRIVED"]')).toHaveText("arrived");
  expect(w.pageErrors).toEqual([]);
});

test("with telemetry off the link shows stale values and their age, not a green dot", async ({ page }) => {
  const w = await open(page);
  await expect(page.locator("#link-dot")).toHaveClass(/dot-connected/);
  await expect(page.locator("#telemetry-age")).toHaveText(`live, ${TELEMETRY_HZ} Hz`);
  try {
    await telemetry(page, 0);
    await expect(page.locator("body")).toHaveAttribute("data-telemetry", "stale", { timeout: 5000 });
    await expect(page.locator("#link-dot")).toHaveClass(/dot-stale/);
    await expect(page.locator("#link-state")).toHaveText(/^connected, no telemetry for \d/);
    await expect(page.locator("#telemetry-age")).toHaveText(/^stale: the last frame came [\d.]+ s ago$/);
    for (const id of ["#pose-x", "#pose-y", "#pose-theta"]) await expect(page.locator(id)).toHaveClass(/stale/);
    // the age keeps growing
    const age = async (): Promise<number> => Number(/came ([\d.]+) s/.exec((await page.locator("#telemetry-age").textContent()) ?? "")?.[1]);
    const a = await age();
    await expect.poll(age).toBeGreaterThan(a + 0.9);
    await page.locator("header").screenshot({ path: `${SHOTS}/stale.png` });
  } finally {
    await telemetry(page, TELEMETRY_HZ);
  }
  await expect(page.locator("body")).toHaveAttribute("data-telemetry", "live");
  await expect(page.locator("#link-dot")).toHaveClass(/dot-connected/);
  await expect(page.locator("#pose-x")).not.toHaveClass(/stale/);
  expect(w.pageErrors).toEqual([]);
});

test("the step response refuses to drive blind when telemetry is off", async ({ page }) => {
  const w = await open(page);
  try {
    await telemetry(page, 0);
    await expect(page.locator("body")).toHaveAttribute("data-telemetry", "stale", { timeout: 5000 });
    const start = await (await page.request.get(`${BASE}/api/status`)).json();
    w.requests.length = 0;
    await page.click("#step-run");
    await expect(page.locator("#step-msg")).toContainText("No step response: telemetry is not arriving");
    await expect(page.locator("#step-msg")).toHaveClass(/form-error/);
    await expect(page.locator("#step-msg")).not.toContainText("overshoot");
    await page.waitForTimeout(1500);
    expect(w.requests.filter((r) => r === "POST /api/drive")).toEqual([]);
    const end = await (await page.request.get(`${BASE}/api/status`)).json();
    expect(Math.hypot(end.pose.x - start.pose.x, end.pose.y - start.pose.y)).toBeLessThan(0.001);
  } finally {
    await telemetry(page, TELEMETRY_HZ);
  }
  expect(w.pageErrors).toEqual([]);
});

test("a step response that runs into a wall is reported as that, not as a tuning result", async ({ page }) => {
  test.setTimeout(45_000);
  const w = await open(page);
  await faceEastWall(page, 0.33); // less than the run's 0.45 m
  await page.click("#step-run");
  await expect(page.locator("#tuning")).toHaveAttribute("data-step", "done", { timeout: 8000 });
  const msg = page.locator("#step-msg");
  await expect(msg).toContainText("Not a tuning result: the cart hit something during the run");
  await expect(msg).toContainText("BUMPER");
  await expect(msg).not.toContainText("overshoot");
  await expect(msg).toHaveClass(/form-error/);
  // back off the wall and away
  await page.locator("#drive-title").click();
  await page.keyboard.down("ArrowDown");
  await page.waitForTimeout(700);
  await page.keyboard.up("ArrowDown");
  await page.waitForTimeout(600); // the panel's last drive, a stop, is sent before the goal
  const p: Point = await pose(page);
  expect(p[0]).toBeLessThan(1.9);
  await gotoAndWait(page, [1.0, 0.8]);
  expect(w.pageErrors).toEqual([]);
});
