// The rmvdsl extension: starts `rmv lsp` (the rmvdsl language server) for .rmv files.
"use strict";

const vscode = require("vscode");
const { LanguageClient, TransportKind } = require("vscode-languageclient/node");

let client;

/** The server's command line: rmv.server.command, else `PYTHON -m rmvdsl.cli lsp`. */
function serverCommand() {
  const config = vscode.workspace.getConfiguration("rmv");
  const custom = config.get("server.command") || [];
  if (custom.length > 0) {
    return { command: custom[0], args: custom.slice(1) };
  }
  const python = config.get("python") || "python3";
  return { command: python, args: ["-m", "rmvdsl.cli", "lsp"] };
}

async function activate(context) {
  const { command, args } = serverCommand();
  const server = { command, args, transport: TransportKind.stdio };
  const options = {
    documentSelector: [{ scheme: "file", language: "rmv" }],
  };
  // The trace level is read by the client from `rmv.trace.server`.
  client = new LanguageClient("rmv", "rmvdsl", server, options);
  context.subscriptions.push(client);
  await client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
