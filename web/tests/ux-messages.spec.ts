// Messages that do not get in the way (issue 12): toasts in a corner that never move the page,
// never cover the map's mode switch or the command form, at most three, each dismissible; and a
// form's own error said once, in the form.

import { expect, test, type Locator, type Page } from "@playwright/test";

import { open, SHOTS, trustPose } from "./helpers";

test.describe.configure({ mode: "serial" });
test.beforeAll(({ request }) => trustPose(request));

type Box = { x: number; y: number; width: number; height: number };

async function box(l: Locator): Promise<Box> {
  const b = await l.boundingBox();
  if (!b) throw new Error("not displayed");
  return b;
}

const overlaps = (a: Box, b: Box): boolean =>
  a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height;

/** `count` different errors, as a failing gateway gives them: the stop answered 409, each time
 * with its own sentence (a stub: the real gateway's stop does not fail on demand). */
async function errors(page: Page, count: number, tag: string): Promise<void> {
  let n = 0;
  await page.route("**/api/stop", (route) =>
    route.fulfill({ status: 409, contentType: "application/json", body: JSON.stringify({ detail: `refused for the test, ${tag} ${++n}` }) }),
  );
  for (let k = 0; k < count; k++) {
    await page.click("#estop");
    await expect(page.locator("#messages")).toContainText(`${tag} ${k + 1}`);
  }
  await page.unroute("**/api/stop");
}

/** That no toast covers what is on screen of the controls given. */
async function uncovered(page: Page, selectors: string[]): Promise<void> {
  const view = page.viewportSize() ?? { width: 0, height: 0 };
  for (const toast of await page.locator("#messages .msg").all()) {
    const t = await box(toast);
    for (const s of selectors) {
      const b = await box(page.locator(s));
      const visible = { x: b.x, y: Math.max(b.y, 0), width: b.width, height: Math.min(b.y + b.height, view.height) - Math.max(b.y, 0) };
      if (visible.height > 0) expect(overlaps(t, visible), `a toast covers ${s}`).toBe(false);
    }
  }
}

for (const [what, viewport] of [
  ["desktop", { width: 1280, height: 900 }],
  ["phone", { width: 390, height: 844 }],
] as const) {
  test(`messages on a ${what} are toasts: the page does not move, nothing needed is covered, three at most, dismissible`, async ({ browser }) => {
    const context = await browser.newContext({ viewport, hasTouch: what === "phone" });
    const page = await context.newPage();
    const w = await open(page);
    const watched = ["#map", ".segmented", "#cmd-form", "#estop"];
    const measure = () => Promise.all(watched.map((s) => box(page.locator(s))));
    // the layout has settled (the header's state after an earlier test's reset, say, or its
    // settings badge once the firmware's first STATUS is in): unchanged over four polls, 2 s, so
    // that what is measured is what the toasts do, not what the page was still doing
    let before = await measure();
    let still = 0;
    await expect
      .poll(
        async () => {
          const now = await measure();
          still = JSON.stringify(now) === JSON.stringify(before) ? still + 1 : 0;
          before = now;
          return still >= 4;
        },
        { intervals: [500], timeout: 30_000 },
      )
      .toBe(true);
    const height = await page.evaluate(() => document.documentElement.scrollHeight);

    await errors(page, 5, "number");
    const toasts = page.locator("#messages .msg");
    await expect(toasts).toHaveCount(3); // the newest three
    await expect(toasts.last()).toContainText("number 5");
    // nothing moved, and the page is as long as it was
    expect(await Promise.all(watched.map((s) => box(page.locator(s))))).toEqual(before);
    expect(await page.evaluate(() => document.documentElement.scrollHeight)).toBe(height);
    // the map's mode switch, the command form and the stop button stay uncovered
    await uncovered(page, [".segmented", "#cmd-form", "#estop"]);
    await page.screenshot({ path: `${SHOTS}/toasts-${what}.png` });
    if (what === "phone") {
      // scrolled until the command form's top is low on the screen, where the toasts were: they
      // move to the top, under the top bar
      await page.evaluate(() => {
        const form = document.getElementById("cmd-form")?.getBoundingClientRect();
        if (form) window.scrollBy(0, form.top - window.innerHeight * 0.7);
      });
      await errors(page, 1, "scrolled");
      await uncovered(page, [".segmented", "#cmd-form", "#estop"]);
      await expect(page.locator("#messages")).toHaveClass(/at-top/);
      await page.evaluate(() => window.scrollTo(0, 0));
    }
    // each is dismissible
    const last = (await toasts.last().textContent()) ?? "";
    await toasts.last().locator("button.msg-close").click();
    await expect(toasts).toHaveCount(2);
    await expect(page.locator("#messages")).not.toContainText(last.replace("×", ""));
    expect(w.pageErrors).toEqual([]);
    await context.close();
  });
}

test("a go-to's error is said once, in the form", async ({ page }) => {
  const w = await open(page);
  await page.fill("#goto-form input[name=x]", "5");
  await page.fill("#goto-form input[name=y]", "5");
  await page.click("#goto-form button[type=submit]");
  await expect(page.locator("#goto-msg")).toContainText("The goal (5.000, 5.000) is off the map");
  await page.waitForTimeout(500);
  await expect(page.getByText("is off the map")).toHaveCount(1);
  // a click off the map in "Go here" mode (the mode the map starts in): said once too, on the map
  // beside the click, where the user looks (the form's line may be below the fold)
  await expect(page.locator("#map")).toHaveAttribute("data-mode", "goto");
  const map = await box(page.locator("#map"));
  await page.locator("#map").click({ position: { x: 3, y: map.height - 3 } }); // beyond the walls
  await expect(page.locator("#map-msg")).toHaveClass(/form-error/);
  await expect(page.locator("#map-msg")).toContainText("is off the map");
  await expect(page.locator("#goto-msg")).toHaveText("");
  await page.waitForTimeout(500);
  await expect(page.getByText("is off the map")).toHaveCount(1);
  await expect(page.locator("#messages .msg")).toHaveCount(0);
  expect(w.pageErrors).toEqual([]);
});
