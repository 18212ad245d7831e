// The pages load as ES modules, and the daemon serves every module they
// import: each page's <script> is `type="module"` from the daemon's own
// files (the Content-Security-Policy allows no inline script), and every
// file a module imports is in src/http/web.rs's FILES table, which serves
// it as text/javascript (a browser refuses a module of another type).
// A module added to web/ and not to that table fails here, before a
// browser test would see the page break.
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync, readdirSync } from "node:fs";
import { fileURLToPath } from "node:url";

const root = fileURLToPath(new URL("../../", import.meta.url));
const web = readdirSync(`${root}web`);
const rust = readFileSync(`${root}src/http/web.rs`, "utf8");
// ("/NAME", include_str!("../../web/NAME")) entries of FILES.
const served = new Map([...rust.matchAll(/\("(\/[\w.-]+)", include_str!\("\.\.\/\.\.\/web\/([\w.-]+)"\)\)/g)]
  .map((m) => [m[1], m[2]]));

test("every page loads only module scripts of the daemon's own files", () => {
  for (const page of web.filter((f) => f.endsWith(".html"))) {
    const tags = [...readFileSync(`${root}web/${page}`, "utf8").matchAll(/<script\b[^>]*>/g)].map((m) => m[0]);
    assert.ok(tags.length >= 1, `${page} has no script`);
    for (const tag of tags) {
      assert.match(tag, /^<script type="module" src="\/[\w.-]+\.js">$/, `${page}: ${tag}`);
      const src = tag.match(/src="([^"]+)"/)[1];
      assert.equal(served.get(src), src.slice(1), `${page} loads ${src}, which src/http/web.rs does not serve`);
    }
  }
});

test("every module a script imports is served at the path the import names", () => {
  let imports = 0;
  for (const script of web.filter((f) => f.endsWith(".js"))) {
    assert.equal(served.get(`/${script}`), script, `web/${script} is not served by src/http/web.rs`);
    const text = readFileSync(`${root}web/${script}`, "utf8");
    for (const m of text.matchAll(/^import\s[^;]*?from\s+"([^"]+)";/gms)) {
      imports += 1;
      assert.match(m[1], /^\.\/[\w.-]+\.js$/, `web/${script} imports ${m[1]}: a relative ./NAME.js (served beside it)`);
      assert.equal(served.get(m[1].slice(1)), m[1].slice(2), `web/${script} imports ${m[1]}, which is not served`);
    }
  }
  assert.ok(imports >= 10, `only ${imports} imports found: the pattern no longer matches the modules`);
});

test("scripts and style are served with their types: JavaScript for modules", () => {
  assert.match(rust, /fn content_type\(path: &str\)[\s\S]*?"text\/css; charset=utf-8"[\s\S]*?"text\/javascript; charset=utf-8"/);
  assert.ok(served.size >= 12, `FILES lists ${served.size}`);
});

test("no module writes markup from a string (the policy's Trusted Types refuse it; names are stored text)", () => {
  for (const script of web.filter((f) => f.endsWith(".js"))) {
    const text = readFileSync(`${root}web/${script}`, "utf8").toLowerCase();
    for (const sink of ["innerhtml", "outerhtml", "insertadjacenthtml", "document.write"]) {
      assert.ok(!text.includes(sink), `web/${script} writes markup with ${sink}`);
    }
  }
});
