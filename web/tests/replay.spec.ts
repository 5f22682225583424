// `cart2d replay` in the panel: a mission's recording played back shows the cart's trail, the
// mission and the plots, says it is a replay, and offers nothing that drives or changes anything.

import { type ChildProcess, spawn, spawnSync } from "node:child_process";
import { mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { createServer } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";

import { expect, test } from "@playwright/test";

import { ROOT } from "./gateway";

const CART2D = join(ROOT, "build", "venv", "bin", "cart2d");
let dir = "";
let replay: ChildProcess | null = null;
let base = "";

function freePort(): Promise<number> {
  return new Promise((ok, fail) => {
    const server = createServer();
    server.once("error", fail);
    server.listen(0, "127.0.0.1", () => {
      const address = server.address();
      const port = typeof address === "object" && address ? address.port : 0;
      server.close(() => ok(port));
    });
  });
}

test.beforeAll(async () => {
  dir = mkdtempSync(join(tmpdir(), "cart2d-replay-"));
  writeFileSync(join(dir, "m.json"), JSON.stringify({ obstacles: [[0.4, 0.2]], goals: [[0.8, 0.4]] }));
  const mission = spawnSync(CART2D, ["mission", join(dir, "m.json")], { cwd: ROOT, encoding: "utf8", timeout: 120_000 });
  expect(mission.status, mission.stderr).toBe(0);
  const port = await freePort();
  base = `http://127.0.0.1:${port}`;
  replay = spawn(CART2D, ["replay", join(dir, "m.mcap"), "--speed", "4", "--port", String(port)], {
    cwd: ROOT,
    env: { ...process.env, CART2D_HOME: dir },
    stdio: "ignore",
  });
  const deadline = Date.now() + 20_000;
  while (Date.now() < deadline) {
    try {
      if ((await fetch(`${base}/api/status`)).ok) return;
    } catch {
      /* not listening yet */
    }
    await new Promise((r) => setTimeout(r, 200));
  }
  throw new Error(`cart2d replay did not come up at ${base}`);
});

test.afterAll(() => {
  replay?.kill("SIGINT");
  rmSync(dir, { recursive: true, force: true });
});

test("a replay shows the recorded mission, says it is a replay and offers no driving", async ({ page }) => {
  const changes: string[] = [];
  page.on("request", (r) => {
    if (r.method() !== "GET") changes.push(`${r.method()} ${new URL(r.url()).pathname}`);
  });
  await page.goto(`${base}/`);
  await expect(page.locator("body")).toHaveAttribute("data-replay", "on");
  await expect(page.locator("#replay-badge")).toContainText("replay of m.mcap");
  for (const control of ["#estop", ".segmented", "#goto-form", "#drive-speed", "#tuning", "#cmd-form"]) {
    await expect(page.locator(control).first()).toBeHidden();
  }
  await expect(page.locator("#map")).toBeVisible();
  await expect(page.locator("#plots")).toBeVisible();
  await expect(page.locator("#truth-pose")).toContainText("x ");
  await expect(page.locator("#replay-badge")).toContainText("(ended)", { timeout: 20_000 });
  await expect(page.locator("#mission-state")).toHaveText("arrived");
  const x = Number(await page.locator("#pose-x").getAttribute("data-value"));
  const y = Number(await page.locator("#pose-y").getAttribute("data-value"));
  expect(Math.hypot(x - 0.8, y - 0.4)).toBeLessThan(0.02); // where the recorded cart arrived
  await page.keyboard.press("ArrowUp");
  await page.keyboard.press("Escape");
  await page.locator("#map").click({ position: { x: 100, y: 100 } });
  await page.waitForTimeout(500);
  expect(changes).toEqual([]);
});
