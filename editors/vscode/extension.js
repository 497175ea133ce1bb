// The fmionnx extension: starts `fmionnx lsp` and hands it fmionnx's files. Everything the
// editor shows (diagnostics, completion, hover, definitions, fixes, renames) comes from the
// server; this file only starts it.
"use strict";

const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

/** The configured executable, with `${workspaceFolder}` replaced by the first folder. */
function command() {
  const configured = vscode.workspace.getConfiguration("fmionnx").get("command", "fmionnx");
  const folder = vscode.workspace.workspaceFolders?.[0]?.uri.fsPath ?? "";
  return configured.replace(/\$\{workspaceFolder\}/g, folder);
}

async function activate(context) {
  const serverOptions = {
    command: command(),
    args: ["lsp"],
    transport: TransportKind.stdio,
  };
  const clientOptions = {
    // The server checks a YAML file only when it has the top-level `fmionnx:` key.
    documentSelector: [
      { scheme: "file", language: "yaml" },
      { scheme: "file", pattern: "**/*.ssd" },
    ],
  };
  client = new LanguageClient("fmionnx", "fmionnx", serverOptions, clientOptions);
  context.subscriptions.push(
    vscode.workspace.onDidChangeConfiguration(async (event) => {
      if (event.affectsConfiguration("fmionnx.command") && client) {
        await client.stop();
        client = new LanguageClient("fmionnx", "fmionnx", { ...serverOptions, command: command() }, clientOptions);
        await client.start();
      }
    }),
  );
  await client.start();
}

async function deactivate() {
  if (client) {
    await client.stop();
  }
}

module.exports = { activate, deactivate };
