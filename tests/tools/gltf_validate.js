#!/usr/bin/env node
// Validates glTF 2.0 files with the Khronos glTF-Validator (npm package `gltf-validator`) and
// prints every issue. Usage: node gltf_validate.js [--modules DIR] FILE.glb|FILE.gltf...
// DIR holds node_modules/gltf-validator (e.g. build/npm, from `npm install --prefix build/npm
// gltf-validator`); without it Node's usual module search applies. Exit codes: 0 when every file
// has 0 errors and 0 warnings, 1 when some file has either (or cannot be read), 77 when the
// package is not installed (the caller skips), 2 on a usage error.
'use strict';
const fs = require('fs');
const path = require('path');

const args = process.argv.slice(2);
let modules = null;
if (args[0] === '--modules') {
    modules = args[1];
    args.splice(0, 2);
}
if (args.length === 0) {
    console.error('usage: gltf_validate.js [--modules DIR] FILE...');
    process.exit(2);
}
let validator;
try {
    validator = modules
        ? require(path.resolve(modules, 'node_modules', 'gltf-validator'))
        : require('gltf-validator');
} catch (e) {
    console.error('gltf-validator is not installed' + (modules ? ' under ' + modules : '') +
                  ' (npm install --prefix DIR gltf-validator)');
    process.exit(77);
}

(async () => {
    let failed = false;
    for (const file of args) {
        let bytes;
        try {
            bytes = new Uint8Array(fs.readFileSync(file));
        } catch (e) {
            console.log(`${file}: cannot read: ${e.message}`);
            failed = true;
            continue;
        }
        const dir = path.dirname(file);
        const report = await validator.validateBytes(bytes, {
            uri: file,
            maxIssues: 0,  // all of them
            externalResourceFunction: (uri) =>
                new Promise((resolve, reject) => {
                    fs.readFile(path.resolve(dir, decodeURIComponent(uri)),
                                (err, data) => err ? reject(err.toString())
                                                   : resolve(new Uint8Array(data)));
                }),
        });
        const i = report.issues;
        console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ` +
                    `${i.numInfos} infos, ${i.numHints} hints (glTF-Validator ${report.validatorVersion})`);
        const names = ['error', 'warning', 'info', 'hint'];
        // One line per distinct code and severity, with a count and the first pointer.
        const groups = new Map();
        for (const m of i.messages) {
            const key = `${names[m.severity]} ${m.code}`;
            const g = groups.get(key);
            if (g) g.count++;
            else groups.set(key, {count: 1, first: m});
        }
        for (const [key, g] of groups)
            console.log(`  ${key} x${g.count}: ${g.first.message}` +
                        (g.first.pointer ? ` (${g.first.pointer})` : ''));
        if (i.numErrors > 0 || i.numWarnings > 0) failed = true;
    }
    process.exit(failed ? 1 : 0);
})();
