// What the firmware's numbers mean, in words, from docs/protocol.md's tables (spec.ts, read at
// build time): a refusal's reason, the modes, the STATUS flags and reset causes, each command's
// description; and the generic-command form's replies decoded with them.

import tables from "virtual:protocol-tables";
import type { Coded, CommandDoc } from "./spec";
import { num } from "./format";

export const PROTOCOL = tables;

export function commandDoc(name: string): CommandDoc | undefined {
  return tables.commands.find((c) => c.name === name);
}

/** CONTROL_ERROR's result: "OUT_OF_RANGE (reason 3): an argument is outside its documented range". */
export function reasonWords(code: number): string {
  const r = tables.reasons.find((x) => x.code === code);
  return r ? `${r.name} (reason ${code}): ${r.meaning}` : `reason ${num(code)}, which this panel does not know`;
}

function bits(word: number, table: Coded[]): Coded[] {
  return table.filter((f) => Math.floor(word / 2 ** f.code) % 2 === 1);
}

/** The flags set in STATUS's `flags` word (bit numbers as docs/protocol.md gives them). */
export function flagsOf(word: number): Coded[] {
  return bits(word, tables.flags);
}

export function flagDoc(name: string): Coded | undefined {
  return tables.flags.find((f) => f.name === name);
}

const SETTINGS_SOURCE = ["EEPROM", "defaults (blank EEPROM)", "defaults (corrupt EEPROM)"];

export interface SettingName {
  id: number;
  name: string;
}

/** One result of a reply, decoded where the protocol gives its numbers a meaning. */
function decodeResult(command: string, name: string, v: number, settings: SettingName[]): string {
  const whole = Number.isInteger(v);
  switch (name) {
    case "mode": {
      const m = tables.modes.find((x) => x.code === v);
      return m ? `${v} (${m.name}: ${m.meaning})` : num(v);
    }
    case "flags": {
      const set = flagsOf(v);
      return set.length ? `${v}: ${set.map((f) => f.name).join(", ")}` : `${v}: none`;
    }
    case "reset_cause": {
      const set = bits(v, tables.resetCauses);
      return set.length ? `${v}: ${set.map((f) => f.name).join(", ")}` : `${v}: none recorded`;
    }
    case "last_error":
      return v === 0 ? "0: none" : `${v}: ${reasonWords(v)}`;
    case "settings_source":
      return whole && SETTINGS_SOURCE[v] ? `${v}: ${SETTINGS_SOURCE[v]}` : num(v);
    case "eeprom_busy":
      return v ? `${v}: writing` : `${v}: idle`;
    case "firmware":
      return command === "VERSION" && whole ? `${Math.floor(v / 10000)}.${Math.floor(v / 100) % 100}.${v % 100}` : num(v);
    case "dictionary":
      return whole ? `0x${v.toString(16).toUpperCase().padStart(4, "0")}` : num(v);
    case "id": {
      const s = settings.find((x) => x.id === v);
      return s ? `${v} (${s.name})` : num(v);
    }
    default:
      return num(v);
  }
}

/** Each result of a reply as "name = value", in words where they have a meaning. A refusal's
 * one result is its reason; a reply whose results do not match the table is shown as numbers. */
export function describeResults(
  command: CommandDoc,
  status: string,
  results: number[],
  settings: SettingName[],
): string[] {
  if (status === "CONTROL_ERROR" && results.length === 1) return [`refused: ${reasonWords(results[0] ?? 0)}`];
  const names = listOf(command.results);
  if (names.length !== results.length) return results.map((v) => num(v));
  return results.map((v, k) => `${names[k]} = ${decodeResult(command.name, names[k] ?? "", v, settings)}`);
}

/** "x, y, theta" → ["x", "y", "theta"]; "–" (none) → []. */
export function listOf(column: string): string[] {
  return column === "–" || column.trim() === "" ? [] : column.split(",").map((s) => s.trim());
}
