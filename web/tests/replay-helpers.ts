// The replay specs' rig: a mission recorded by `cart2d mission` and `cart2d replay` serving it on
// a free port with a fresh CART2D_HOME, stopped with SIGINT.

import { type ChildProcess, spawn, spawnSync } from "node:child_process";
import { writeFileSync } from "node:fs";
import { join } from "node:path";

import { freePort, ROOT } from "./gateway";

const CART2D = join(ROOT, "build", "venv", "bin", "cart2d");

/** Runs the mission `spec` (written to DIR/m.json) headless; its recording is DIR/m.mcap. */
export function recordMission(dir: string, spec: Record<string, unknown>, timeoutMs = 120_000): string {
  writeFileSync(join(dir, "m.json"), JSON.stringify(spec));
  const run = spawnSync(CART2D, ["mission", join(dir, "m.json")], { cwd: ROOT, encoding: "utf8", timeout: timeoutMs });
  if (run.status !== 0) throw new Error(`cart2d mission failed (${run.status}): ${run.stderr}`);
  return join(dir, "m.mcap");
}

export interface Replay {
  base: string; // http://127.0.0.1:<port>
  stop: () => void;
}

/** `cart2d replay FILE ARGS` on a free port, once it answers /api/status. */
export async function startReplay(file: string, home: string, args: string[] = []): Promise<Replay> {
  const port = await freePort();
  const base = `http://127.0.0.1:${port}`;
  const child: ChildProcess = spawn(CART2D, ["replay", file, ...args, "--port", String(port)], {
    cwd: ROOT,
    env: { ...process.env, CART2D_HOME: home },
    stdio: "ignore",
  });
  const stop = (): void => void child.kill("SIGINT");
  const deadline = Date.now() + 20_000;
  while (Date.now() < deadline) {
    try {
      if ((await fetch(`${base}/api/status`)).ok) return { base, stop };
    } catch {
      /* not listening yet */
    }
    await new Promise((r) => setTimeout(r, 200));
  }
  stop();
  throw new Error(`cart2d replay did not come up at ${base}`);
}
