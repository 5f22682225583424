import { readFileSync } from "node:fs";
import { fileURLToPath } from "node:url";
import { defineConfig, type Plugin } from "vite";

import { tablesOf } from "./src/spec";

// The built panel goes into the Python package, so the gateway serves it with no Node at run
// time. `npm run dev` proxies the API to a gateway on :8080 (`cart2d sim`).
const gateway = process.env.CART2D_GATEWAY ?? "http://127.0.0.1:8080";
const PROTOCOL = fileURLToPath(new URL("../docs/protocol.md", import.meta.url));

/** `import tables from "virtual:protocol-tables"`: docs/protocol.md's tables (src/spec.ts),
 * read when the panel is built. */
function protocolTables(): Plugin {
  const id = "virtual:protocol-tables";
  return {
    name: "cart2d-protocol-tables",
    resolveId: (source) => (source === id ? `\0${id}` : null),
    load(source) {
      if (source !== `\0${id}`) return null;
      this.addWatchFile(PROTOCOL);
      return `export default ${JSON.stringify(tablesOf(readFileSync(PROTOCOL, "utf8")))};`;
    },
  };
}

export default defineConfig({
  root: fileURLToPath(new URL(".", import.meta.url)),
  base: "./",
  plugins: [protocolTables()],
  build: {
    outDir: fileURLToPath(new URL("../cart2d/panel", import.meta.url)),
    emptyOutDir: true,
    target: "es2022",
    chunkSizeWarningLimit: 200,
    // the control panel and the fleet manager's page (`cart2d fleet` serves fleet.html)
    rollupOptions: {
      input: {
        panel: fileURLToPath(new URL("index.html", import.meta.url)),
        fleet: fileURLToPath(new URL("fleet.html", import.meta.url)),
      },
    },
  },
  server: {
    proxy: {
      "/api": gateway,
      "/ws": { target: gateway.replace(/^http/, "ws"), ws: true },
    },
  },
});
