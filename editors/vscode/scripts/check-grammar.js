// Tokenizes every .vrs file of the repository with VS Code's own TextMate engine (vscode-textmate
// with Oniguruma) and reports non-whitespace text left without a scope, and text scoped invalid.
// Run: `npm install && npm run check-grammar` here (the Rust test lsp/tests/grammar.rs checks the
// same without Node, against the compiler's lexer).
const fs = require("fs"), path = require("path");
const vsctm = require("vscode-textmate"), oniguruma = require("vscode-oniguruma");
const wasm = fs.readFileSync(require.resolve("vscode-oniguruma/release/onig.wasm")).buffer;
const lib = oniguruma.loadWASM(wasm).then(() => ({
  createOnigScanner: (p) => new oniguruma.OnigScanner(p),
  createOnigString: (s) => new oniguruma.OnigString(s),
}));
const root = process.argv[2] || path.join(__dirname, "../../..");
const registry = new vsctm.Registry({
  onigLib: lib,
  loadGrammar: async () => vsctm.parseRawGrammar(fs.readFileSync(path.join(root, "editors/vscode/syntaxes/vrs.tmLanguage.json"), "utf8"), "vrs.tmLanguage.json"),
});
function walk(dir, out) {
  for (const e of fs.readdirSync(dir, { withFileTypes: true })) {
    const p = path.join(dir, e.name);
    if (e.isDirectory()) walk(p, out); else if (p.endsWith(".vrs")) out.push(p);
  }
  return out;
}
registry.loadGrammar("source.vrs").then((grammar) => {
  let files = 0, tokens = 0, problems = 0, invalid = 0;
  for (const dir of ["stdlib", "examples", "tests/fixtures"]) {
    for (const file of walk(path.join(root, dir), [])) {
      files++;
      let state = vsctm.INITIAL;
      fs.readFileSync(file, "utf8").split("\n").forEach((line, n) => {
        const r = grammar.tokenizeLine(line, state);
        for (const t of r.tokens) {
          const text = line.slice(t.startIndex, t.endIndex);
          tokens++;
          if (t.scopes.length < 2 && text.trim() !== "") { problems++; console.log(`${file}:${n + 1}: unscoped \`${text}\``); }
          if (t.scopes.some((s) => s.startsWith("invalid."))) { invalid++; console.log(`${file}:${n + 1}: invalid \`${text}\``); }
        }
        state = r.ruleStack;
      });
    }
  }
  console.log(`${files} files, ${tokens} tokens, ${problems} unscoped, ${invalid} invalid`);
  process.exitCode = problems > 0 ? 1 : 0;
});
