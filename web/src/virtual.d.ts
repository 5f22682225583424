// Modules vite.config.ts makes at build time.

declare module "virtual:protocol-tables" {
  const tables: import("./spec").ProtocolTables;
  export default tables;
}
