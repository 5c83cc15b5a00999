// Starts `vrsc lsp` for .vrs files (and watches scene files, whose changes re-check modules).
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const command = vscode.workspace.getConfiguration("vrs").get("server.path") || "vrsc";
  const server = { command, args: ["lsp"] };
  client = new LanguageClient(
    "vrs",
    "VRS language server",
    { run: server, debug: server },
    {
      documentSelector: [{ scheme: "file", language: "vrs" }, { scheme: "untitled", language: "vrs" }],
      synchronize: { fileEvents: vscode.workspace.createFileSystemWatcher("**/*.toml") },
    },
  );
  context.subscriptions.push({ dispose: () => client && client.stop() });
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
