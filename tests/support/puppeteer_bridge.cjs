// Firefox for the browser tests: one page of Debian's Firefox ESR, driven by puppeteer-core over
// WebDriver BiDi, answering commands from tests/support/puppeteer.py.
//
//   node puppeteer_bridge.cjs <puppeteer-core folder> <firefox binary> <width> <height>
//
// Each line on stdin is a command, {"op": ..., ...}; each line on stdout the answer to one, in
// order: {"ok": true, "value": ...} or {"ok": false, "error": "..."}. The first line out says
// the browser is up, with its version. Operations: goto {url, timeout}, click {selector},
// wait {selector, gone, timeout}, evaluate {expression}, url, errors, close. puppeteer-core
// downloads nothing: it starts the Firefox it is given.
"use strict";

const readline = require("node:readline");

const [folder, firefox, width, height] = process.argv.slice(2);
const puppeteer = require(folder);

function answer(message) {
  process.stdout.write(JSON.stringify(message) + "\n");
}

async function main() {
  const browser = await puppeteer.launch({
    browser: "firefox",
    executablePath: firefox,
    headless: true,
    defaultViewport: { width: Number(width), height: Number(height) },
  });
  const page = await browser.newPage();
  const errors = [];
  page.on("pageerror", (error) => errors.push(String((error && error.message) || error)));
  answer({ ok: true, value: await browser.version() });

  const operations = {
    goto: (c) => page.goto(c.url, { timeout: c.timeout, waitUntil: "load" }).then(() => null),
    click: (c) => page.click(c.selector).then(() => null),
    // "gone": no element matches any more (or none is shown); otherwise one is in the document.
    wait: (c) =>
      page.waitForSelector(c.selector, { hidden: !!c.gone, timeout: c.timeout }).then(() => null),
    evaluate: (c) => page.evaluate(c.expression),
    url: () => page.url(),
    errors: () => errors,
  };
  const lines = readline.createInterface({ input: process.stdin });
  for await (const line of lines) {
    const command = JSON.parse(line);
    if (command.op === "close") break;
    try {
      const value = await operations[command.op](command);
      answer({ ok: true, value: value === undefined ? null : value });
    } catch (error) {
      answer({ ok: false, error: `${command.op}: ${(error && error.message) || error}` });
    }
  }
  await browser.close();
  answer({ ok: true, value: null });
}

main().catch((error) => {
  answer({ ok: false, error: `firefox: ${(error && error.message) || error}` });
  process.exit(1);
});
