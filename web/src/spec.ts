// The protocol's tables (docs/protocol.md, the one source of truth the firmware and the gateway
// are generated from and tested against) as data for the panel: reasons, modes, flags, reset
// causes and what each command does. vite.config.ts runs tablesOf() at build time, so the panel
// carries the tables, not the whole document. Plain TypeScript: it runs in Node and in the page.

export interface CommandDoc {
  code: number;
  name: string; // as POST /api/command takes it: COMMAND_ dropped
  args: string;
  results: string;
  notes: string;
}

export interface Coded {
  code: number; // the reason or mode number, or the bit of a flag or a reset cause
  name: string;
  meaning: string;
}

export interface ProtocolTables {
  commands: CommandDoc[];
  reasons: Coded[];
  modes: Coded[];
  flags: Coded[];
  resetCauses: Coded[];
}

/** The markdown tables of `text`, keyed by their first header cell (as cart2d/spec.py does). */
function markdownTables(text: string): Map<string, string[][]> {
  const tables = new Map<string, string[][]>();
  const lines = text.split("\n");
  const cells = (line: string): string[] =>
    line
      .trim()
      .replace(/^\|/, "")
      .replace(/\|$/, "")
      .split("|")
      .map((c) => c.trim());
  for (let i = 0; i + 1 < lines.length; i++) {
    const line = lines[i] ?? "";
    if (!line.startsWith("|") || !(lines[i + 1] ?? "").startsWith("|---")) continue;
    const rows: string[][] = [];
    let k = i + 2;
    for (; k < lines.length && (lines[k] ?? "").startsWith("|"); k++) rows.push(cells(lines[k] ?? ""));
    tables.set(cells(line)[0] ?? "", rows);
    i = k - 1;
  }
  return tables;
}

/** Markdown's inline code and emphasis marks, dropped: the panel shows plain words. */
function plain(text: string): string {
  return text.replace(/`([^`]*)`/g, "$1").replace(/\*\*([^*]*)\*\*/g, "$1");
}

function coded(rows: string[][] | undefined, what: string): Coded[] {
  if (!rows || rows.length === 0) throw new Error(`docs/protocol.md has no ${what} table`);
  return rows.map(([code, name, meaning]) => ({ code: Number(code), name: name ?? "", meaning: plain(meaning ?? "") }));
}

export function tablesOf(text: string): ProtocolTables {
  const t = markdownTables(text);
  const commands = t.get("code");
  if (!commands || commands.length === 0) throw new Error("docs/protocol.md has no command table");
  return {
    commands: commands.map(([code, name, args, results, notes]) => ({
      code: Number(code),
      name: (name ?? "").replace(/^COMMAND_/, ""),
      args: args ?? "",
      results: results ?? "",
      notes: plain(notes ?? ""),
    })),
    reasons: coded(t.get("reason"), "reason"),
    modes: coded(t.get("mode"), "mode"),
    flags: coded(t.get("flag bit"), "flag"),
    resetCauses: coded(t.get("cause bit"), "reset cause"),
  };
}
