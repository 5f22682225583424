// Starts the gateway every test uses (see gateway.ts) and stops it after the tests.

import { existsSync } from "node:fs";
import { join } from "node:path";

import { ROOT, startGateway } from "./gateway";

export default async function globalSetup(): Promise<() => Promise<void>> {
  if (!existsSync(join(ROOT, "cart2d", "panel", "index.html"))) {
    throw new Error("the panel is not built (cart2d/panel/index.html): run make panel");
  }
  const gateway = await startGateway();
  process.env["CART2D_URL"] = gateway.base;
  await gateway.waitConnected();
  process.env["CART2D_SIM_CONTROL"] = gateway.simulator(); // its side channel: the reset button
  return gateway.stop;
}
