import { fileURLToPath } from "node:url";
import { defineConfig } from "vite";

// The built panel goes into the Python package, so the gateway serves it with no Node at run
// time. `npm run dev` proxies the API to a gateway on :8080 (`cart2d sim`).
const gateway = process.env.CART2D_GATEWAY ?? "http://127.0.0.1:8080";

export default defineConfig({
  root: fileURLToPath(new URL(".", import.meta.url)),
  base: "./",
  build: {
    outDir: fileURLToPath(new URL("../cart2d/panel", import.meta.url)),
    emptyOutDir: true,
    target: "es2022",
    chunkSizeWarningLimit: 200,
  },
  server: {
    proxy: {
      "/api": gateway,
      "/ws": { target: gateway.replace(/^http/, "ws"), ws: true },
    },
  },
});
