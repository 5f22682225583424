// Starts `cart2d sim` (the simulator and the gateway serving the built panel) on a free port
// with a fresh CART2D_HOME, waits until the robot answers, and stops it after the tests.

import { spawn } from "node:child_process";
import { existsSync, mkdtempSync, rmSync } from "node:fs";
import { createServer } from "node:net";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";

const ROOT = resolve(import.meta.dirname, "..", "..");

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

async function waitConnected(base: string, log: () => string, timeoutMs = 30_000): Promise<void> {
  const deadline = Date.now() + timeoutMs;
  while (Date.now() < deadline) {
    try {
      const r = await fetch(`${base}/api/status`);
      if (r.ok) {
        const s = (await r.json()) as { link: { state: string }; pose?: unknown };
        if (s.link.state === "connected" && s.pose) return;
      }
    } catch {
      /* not listening yet */
    }
    await new Promise((r) => setTimeout(r, 200));
  }
  throw new Error(`cart2d sim did not come up at ${base}:\n${log()}`);
}

export default async function globalSetup(): Promise<() => Promise<void>> {
  const cart2d = join(ROOT, "build", "venv", "bin", "cart2d");
  if (!existsSync(cart2d)) throw new Error(`${cart2d} is missing: run make python-env sim firmware`);
  if (!existsSync(join(ROOT, "cart2d", "panel", "index.html"))) {
    throw new Error("the panel is not built (cart2d/panel/index.html): run make panel");
  }
  const home = mkdtempSync(join(tmpdir(), "cart2d-panel-"));
  const port = await freePort();
  let output = "";
  const child = spawn(cart2d, ["sim", "--speed", "1", "--port", String(port)], {
    cwd: ROOT,
    env: { ...process.env, CART2D_HOME: home },
    stdio: ["ignore", "pipe", "pipe"],
  });
  child.stdout.on("data", (d: Buffer) => (output += d.toString()));
  child.stderr.on("data", (d: Buffer) => (output += d.toString()));
  const base = `http://127.0.0.1:${port}`;
  process.env["CART2D_URL"] = base;
  await waitConnected(base, () => output);

  return async () => {
    const exited = new Promise<void>((ok) => {
      if (child.exitCode !== null) ok();
      else child.once("exit", () => ok());
    });
    child.kill("SIGINT");
    const timer = setTimeout(() => child.kill("SIGKILL"), 5000);
    await exited;
    clearTimeout(timer);
    rmSync(home, { recursive: true, force: true });
  };
}
