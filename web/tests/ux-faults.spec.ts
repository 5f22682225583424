// The simulator's faults from the panel (issue 12): shown only in simulation, one field per fault
// with its range and explanation; an encoder-radius fault applied from the panel reaches the
// simulator and makes odometry turn away from the true pose while the cart drives straight;
// "All off" clears it; a bad value is refused in the form's own message line.

import { expect, test, type Page } from "@playwright/test";

import { BASE, gotoAndWait, open, type Point, SHOTS, trustPose } from "./helpers";

test.describe.configure({ mode: "serial" });
test.beforeAll(async ({ request }) => {
  await trustPose(request);
  expect((await request.put(`${BASE}/api/sim/faults`, { data: {} })).ok()).toBe(true);
});

interface Heading {
  odometry: number; // rad, the firmware's telemetry
  truth: number; // rad, the simulator's true pose
  truthXY: Point;
}

/** The latest telemetry and true pose the panel receives on /ws (start before open()). */
function watchHeadings(page: Page): () => Heading {
  const last: Heading = { odometry: NaN, truth: NaN, truthXY: [NaN, NaN] };
  page.on("websocket", (ws) =>
    ws.on("framereceived", ({ payload }) => {
      if (typeof payload !== "string") return;
      // a frame: an array of messages, oldest first (cart2d/server/live.py)
      for (const m of JSON.parse(payload) as { type: string; x: number; y: number; theta: number }[]) {
        if (m.type === "telemetry") last.odometry = m.theta;
        else if (m.type === "truth") {
          last.truth = m.theta;
          last.truthXY = [m.x, m.y];
        }
      }
    }),
  );
  return () => ({ ...last });
}

const wrap = (a: number): number => Math.atan2(Math.sin(a), Math.cos(a));

/** How much more the true heading turned than odometry says, driving to `to` (rad). */
async function headingDrift(page: Page, now: () => Heading, to: Point): Promise<number> {
  const a = now();
  await gotoAndWait(page, to);
  await page.waitForTimeout(300); // the last frames after the stop
  const b = now();
  for (const v of [a.odometry, a.truth, b.odometry, b.truth]) expect(Number.isFinite(v)).toBe(true);
  return wrap(b.truth - a.truth) - wrap(b.odometry - a.odometry);
}

async function simFaults(page: Page): Promise<Record<string, number>> {
  const r = await page.request.get(`${BASE}/api/sim/faults`);
  expect(r.ok()).toBe(true);
  return ((await r.json()) as { faults: Record<string, number> }).faults;
}

test.afterAll(async ({ request }) => {
  // leave the next files a simulator without faults, and odometry where the cart really is
  await request.put(`${BASE}/api/sim/faults`, { data: {} });
});

test("an encoder-radius fault set from the panel reaches the simulator and odometry drifts; All off clears it", async ({ page }) => {
  const now = watchHeadings(page);
  const w = await open(page);
  const box = page.locator("#sim-faults");
  await expect(box).toBeVisible();
  const row = box.locator('.fault-row[data-fault="enc_radius_scale_l"]');
  const input = row.locator("input");
  await expect(input).toHaveValue("1");
  await expect(row.locator(".tune-range")).toHaveText("0.5 … 2");
  await expect(box.locator(".fault-row")).toHaveCount(15); // every key of cart2d/simulation/faults.py
  const doc = row.locator(".tune-doc");
  await expect(doc).toBeHidden();
  await row.locator(".tune-name").click();
  await expect(doc).toBeVisible();
  await expect(doc).toContainText("nominal radius of the left measuring wheel");

  // facing east with room ahead; first without the fault: odometry follows the true heading
  await gotoAndWait(page, [0.3, 0.8]);
  await gotoAndWait(page, [0.5, 0.8]);
  const clean = await headingDrift(page, now, [0.9, 0.8]);
  expect(Math.abs(clean), `without faults: ${clean} rad`).toBeLessThan(0.04);

  await input.fill("1.1");
  await expect(row).toHaveAttribute("data-unapplied", "true");
  await box.getByRole("button", { name: "Apply" }).click();
  await expect(box.locator("#faults-msg")).toContainText("enc_radius_scale_l = 1.1");
  await expect(row).not.toHaveAttribute("data-unapplied", "true");
  const set = await simFaults(page);
  expect(set["enc_radius_scale_l"]).toBeCloseTo(1.1, 9);
  expect(set["enc_radius_scale_r"]).toBe(1);
  expect(set["enc_slip_l"]).toBe(0);

  // the left measuring wheel is 10 % larger than the firmware thinks: it counts short, so the
  // controller drives the left side faster and the cart really turns right (clockwise) while
  // odometry says straight; 0.1 × 0.6 m / 0.305 m track ≈ 0.2 rad (config/robot.toml)
  const drift = await headingDrift(page, now, [1.5, 0.8]);
  expect(drift, `with enc_radius_scale_l = 1.1: ${drift} rad`).toBeLessThan(-0.1);
  await box.screenshot({ path: `${SHOTS}/faults-form.png` });
  await page.locator("#truth-row").screenshot({ path: `${SHOTS}/faults-drift.png` });

  await box.getByRole("button", { name: "All off" }).click();
  await expect(box.locator("#faults-msg")).toContainText("All faults off");
  await expect(input).toHaveValue("1");
  expect((await simFaults(page))["enc_radius_scale_l"]).toBe(1);

  // odometry back to where the cart really is, for the files after this one
  const t = now();
  const r = await page.request.post(`${BASE}/api/pose`, { data: { x: t.truthXY[0], y: t.truthXY[1], theta: wrap(t.truth) } });
  expect(r.ok(), await r.text()).toBe(true);
  expect(w.pageErrors).toEqual([]);
});

test("a value out of range is refused in the form's own message line, and nothing is sent", async ({ page }) => {
  const w = await open(page);
  const box = page.locator("#sim-faults");
  const input = box.locator('.fault-row[data-fault="enc_slip_r"] input');
  await input.fill("1.5");
  w.requests.length = 0;
  await box.getByRole("button", { name: "Apply" }).click();
  const msg = box.locator("#faults-msg");
  await expect(msg).toHaveClass(/form-error/);
  await expect(msg).toContainText("enc_slip_r must be between 0 and 0.99");
  await expect(input).toHaveAttribute("aria-invalid", "true");
  await expect(page.locator("#messages")).not.toContainText("enc_slip_r"); // not a banner
  await page.waitForTimeout(300);
  expect(w.requests).toEqual([]);
  expect((await simFaults(page))["enc_slip_r"]).toBe(0);
});

test("on a real cart (GET answers 404) the form stays hidden", async ({ page }) => {
  await page.route("**/api/sim/faults", (route) =>
    route.fulfill({ status: 404, contentType: "application/json", body: JSON.stringify({ detail: "there is no simulator" }) }),
  );
  const asked = page.waitForResponse("**/api/sim/faults");
  const w = await open(page);
  expect((await asked).status()).toBe(404);
  await page.waitForTimeout(200); // the answer handled
  await expect(page.locator("#sim-faults")).toHaveCount(1);
  await expect(page.locator("#sim-faults")).toBeHidden();
  await expect(page.locator("#messages")).not.toContainText("simulator");
  expect(w.pageErrors).toEqual([]);
});
