// The fleet page (web/fleet.html) against a real `cart2d fleet sim --carts 2`: two simulated
// carts (the real firmware each) on a mosquitto it starts, the manager serving the built page.
// A click on the map is a goal a cart reaches; a cart is paused, resumed and cancelled on its way;
// STOP ALL stops one; what the manager refuses is said in a sentence; the page follows the
// manager's live stream (/ws) and polls only while it is down.

import { type ChildProcess, spawn } from "node:child_process";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { expect, test, type Page } from "@playwright/test";

import type { CartView, FleetView } from "../src/generated/fleet";
import { freePort, ROOT, stopChild } from "./gateway";
import { clickMap, SHOTS, type Point } from "./helpers";

let fleet: ChildProcess;
let home = "";
let base = "";
let output = "";

async function fleetView(): Promise<FleetView> {
  const answer = await fetch(`${base}/api/fleet`);
  return (await answer.json()) as FleetView;
}

async function cart(name: string): Promise<CartView> {
  const found = (await fleetView()).carts.find((c) => c.name === name);
  if (!found) throw new Error(`the manager has no ${name}:\n${output}`);
  return found;
}

const distance = (a: readonly number[], b: readonly number[]): number =>
  Math.hypot((a[0] ?? 0) - (b[0] ?? 0), (a[1] ?? 0) - (b[1] ?? 0));

async function place(name: string): Promise<Point> {
  const p = (await cart(name)).position;
  if (!p) throw new Error(`${name} has no position`);
  return [p[0], p[1]];
}

// Waits for the newest goal to end and expects it reached; a goal that failed or was cancelled
// is told with what the manager and the cart said (its VDA 5050 errors, the fleet sim's output).
async function expectReached(page: Page, name: string): Promise<void> {
  const first = page.locator("#goals li").first();
  await expect(first).toHaveAttribute("data-status", /^(reached|failed|cancelled)$/, { timeout: 20_000 });
  const status = await first.getAttribute("data-status");
  if (status === "reached") return;
  const view = await fleetView();
  const goals = view.goals.slice(-3);
  const why = JSON.stringify({ goals, cart: view.carts.find((c) => c.name === name) }, null, 1);
  throw new Error(`${name}'s goal ${status}, not reached:\n${why}\n${output.slice(-4000)}`);
}

async function openFleet(page: Page): Promise<string[]> {
  const errors: string[] = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  page.on("console", (m) => {
    if (m.type() === "error") errors.push(m.text());
  });
  await page.goto(`${base}/`);
  await expect(page.locator("body")).toHaveAttribute("data-manager", "connected");
  await expect(page.locator("#map")).toHaveAttribute("data-carts", "2");
  return errors;
}

test.describe.configure({ mode: "serial" });

test.beforeAll(async () => {
  test.setTimeout(60_000);
  home = mkdtempSync(join(tmpdir(), "cart2d-fleet-"));
  const port = await freePort();
  base = `http://127.0.0.1:${port}`;
  const args = ["fleet", "sim", "--carts", "2", "--port", String(port), "--broker-port", String(await freePort())];
  fleet = spawn(join(ROOT, "build", "venv", "bin", "cart2d"), args, {
    cwd: ROOT,
    env: { ...process.env, CART2D_HOME: home },
    stdio: ["ignore", "pipe", "pipe"],
  });
  fleet.stdout?.on("data", (d: Buffer) => (output += d.toString()));
  fleet.stderr?.on("data", (d: Buffer) => (output += d.toString()));
  await expect
    .poll(async () => (await fleetView().catch(() => null))?.carts.filter((c) => c.position).length ?? 0, {
      timeout: 45_000,
      message: `cart2d fleet sim did not come up at ${base}`,
    })
    .toBe(2);
});

test.afterAll(async () => {
  await stopChild(fleet);
  rmSync(home, { recursive: true, force: true });
});

test("a click on the map is a goal: for the cart chosen, or the nearest idle one; each reaches it", async ({ page }) => {
  const errors = await openFleet(page);
  await expect(page.locator("#goal-cart option")).toHaveText(["the nearest idle cart", "cart1", "cart2"]);
  const [x2, y2] = await place("cart2");
  await page.locator("#goal-cart").selectOption("cart2");
  await clickMap(page, [x2 + 0.02, y2 + 0.48]); // near the node north of cart2
  await expect(page.locator("#fleet-msg")).toContainText("for cart2");
  const first = page.locator("#goals li").first();
  await expect(first).toHaveAttribute("data-status", "reached", { timeout: 20_000 });
  await expect(first).toContainText("cart2");
  expect(distance((await cart("cart2")).position ?? [], [x2, y2 + 0.5])).toBeLessThan(0.15);
  await expect(page.locator('tr[data-cart="cart2"]')).toHaveAttribute("data-state", "idle");

  const [x1, y1] = await place("cart1");
  await page.locator("#goal-cart").selectOption("");
  await clickMap(page, [x1, y1 + 0.5]); // cart1 is nearer than cart2 now is
  await expect(page.locator("#fleet-msg")).toContainText("for the nearest idle cart");
  await expect(page.locator("#goals li").first()).toContainText("cart1");
  await expect(page.locator("#goals li").first()).toHaveAttribute("data-status", "reached", { timeout: 20_000 });
  expect(distance((await cart("cart1")).position ?? [], [x1, y1 + 0.5])).toBeLessThan(0.15);
  expect(errors).toEqual([]);
});

test("a cart paused, resumed and cancelled on its way; STOP ALL stops the other", async ({ page }) => {
  await openFleet(page);
  const speed = async (name: string): Promise<number> => Math.abs((await fleetView()).truth?.carts[name]?.v ?? 1);
  const [x1, y1] = await place("cart1");
  const goal: Point = [x1, y1 + 2.5];
  await page.locator("#goal-cart").selectOption("cart1");
  await clickMap(page, goal);
  const row = page.locator('tr[data-cart="cart1"]');
  await expect(row).toHaveAttribute("data-state", "driving", { timeout: 10_000 });
  await expect.poll(async () => distance(await place("cart1"), [x1, y1])).toBeGreaterThan(0.05);
  await page.screenshot({ path: `${SHOTS}/fleet-driving.png` });

  await row.getByRole("button", { name: "Pause" }).click();
  await expect(page.locator("#fleet-msg")).toHaveText("startPause sent to cart1.");
  await expect(row).toHaveAttribute("data-state", "paused");
  await expect.poll(() => speed("cart1"), { timeout: 10_000 }).toBeLessThan(0.005);
  const held = await place("cart1");
  await row.getByRole("button", { name: "Resume" }).click();
  await expect(page.locator("#fleet-msg")).toHaveText("stopPause sent to cart1.");
  await expect(row).toHaveAttribute("data-state", "driving");
  await expect.poll(async () => distance(await place("cart1"), held)).toBeGreaterThan(0.05);

  await row.getByRole("button", { name: "Cancel" }).click();
  await expect(page.locator("#fleet-msg")).toHaveText("cancelOrder sent to cart1.");
  await expect(page.locator("#goals li").first()).toHaveAttribute("data-status", "cancelled");
  await expect(row.locator('[data-field="order"]')).toHaveText("–");
  await expect.poll(() => speed("cart1"), { timeout: 10_000 }).toBeLessThan(0.005);
  expect(distance(await place("cart1"), goal)).toBeGreaterThan(1.0);

  const [x2, y2] = await place("cart2");
  await page.locator("#goal-cart").selectOption("cart2");
  await clickMap(page, [x2, y2 + 2.5]);
  const row2 = page.locator('tr[data-cart="cart2"]');
  await expect(row2).toHaveAttribute("data-state", "driving", { timeout: 10_000 });
  await page.locator("#stop-all").click();
  await expect(page.locator("#fleet-msg")).toHaveText("STOP ALL: every cart stopped, its order cancelled.");
  await expect(page.locator("#goals li").first()).toHaveAttribute("data-status", "cancelled");
  // stopped and idle: the navigation error of the gateway's own stop (which comes first) goes
  // with the cancelled order
  await expect(row2).toHaveAttribute("data-state", "idle", { timeout: 10_000 });
  await expect.poll(() => speed("cart2"), { timeout: 10_000 }).toBeLessThan(0.005);
  expect(distance(await place("cart2"), [x2, y2 + 2.5])).toBeGreaterThan(1.0);
});

test("what the manager refuses is said in a sentence, and nothing is sent", async ({ page }) => {
  await openFleet(page);
  const goals = (await fleetView()).goals.length;
  const nodes = (await fleetView()).lattice.nodes;
  const corner: Point = [Math.min(...nodes.map((n) => n[0])) - 0.45, Math.min(...nodes.map((n) => n[1])) - 0.45];
  await clickMap(page, corner);
  const msg = page.locator("#fleet-msg");
  await expect(msg).toHaveText(/^\(-0\.\d\d, -0\.\d\d\) is not in the arena's free space\.$/);
  await expect(msg).toHaveClass(/form-error/);
  expect((await fleetView()).goals.length).toBe(goals);

  await expect(page.locator('tr[data-cart="cart1"]')).toHaveAttribute("data-state", /^(idle|error)$/);
  await page.locator('tr[data-cart="cart1"]').getByRole("button", { name: "Cancel" }).click();
  await expect(msg).toHaveText("There is nothing to cancel: cart1 drives no order.");
  await expect(msg).toHaveClass(/form-error/);
});

/** A goal half a metre north of `name`, given on the map for it: shown assigned, then reached. */
async function goalNorthOf(page: Page, name: string): Promise<void> {
  const [x, y] = await place(name);
  await page.locator("#goal-cart").selectOption(name);
  await clickMap(page, [x, y + 0.5]);
  await expect(page.locator("#goals li").first()).toContainText(name);
  await expectReached(page, name);
}

test("the page follows the manager's live stream, polls while the socket is down, and takes the stream back", async ({ page }) => {
  test.setTimeout(60_000); // two goals driven and a reconnection
  let down = false;
  const sockets: { close: () => Promise<void> }[] = [];
  await page.routeWebSocket("**/ws", (ws) => {
    if (down) {
      void ws.close(); // the manager's stream is unreachable: the page must poll
      return;
    }
    ws.connectToServer(); // passed through as it is
    sockets.push(ws);
  });
  let polls = 0;
  page.on("request", (r) => {
    if (r.method() === "GET" && new URL(r.url()).pathname === "/api/fleet") polls += 1;
  });
  await openFleet(page);
  await expect(page.locator("body")).toHaveAttribute("data-feed", "stream");
  await expect(page.locator("#manager-state")).toHaveText("manager connected (live)");

  // live: a goal is shown assigned, then reached, with no poll at all
  polls = 0;
  await goalNorthOf(page, "cart1");
  expect(polls).toBe(0);

  // the socket drops (and cannot come back): the page polls and still follows the manager
  down = true;
  for (const ws of sockets) await ws.close();
  await expect(page.locator("body")).toHaveAttribute("data-feed", "polling");
  await expect(page.locator("#manager-state")).toHaveText("manager connected (polling)");
  await goalNorthOf(page, "cart2");
  expect(polls).toBeGreaterThan(0);

  // the stream is back: the page takes it again (its retries are at most 5 s apart)
  down = false;
  await expect(page.locator("body")).toHaveAttribute("data-feed", "stream", { timeout: 10_000 });
  await expect(page.locator("#manager-state")).toHaveText("manager connected (live)");
});
