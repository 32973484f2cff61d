// SPDX-License-Identifier: GPL-3.0-or-later
//
// A stand-in for what Flamenco Manager gives a job compiler script, written from Flamenco's
// job-type documentation and its job compiler (internal/manager/job_compilers): the Manager
// compiles each scripts/*.js file in strict mode into a goja runtime of its own and runs it
// with these globals and no module system (no require, module or exports):
//   print, alert, formatTimestampLocal  (the Manager also sets frameChunker, frameCount,
//                                        shellSplit and process, which luxel_bake.js does not use)
//   author.Task(name, type), author.Command(name, parameters[, totalStepCount])
//   path.basename, path.dirname, path.join, path.stem  (Flamenco's crosspath: a backslash is a
//                                                       separator too; results use "/")
// Then it reads JOB_TYPE and calls compileJob(job) with the job being compiled. Go structs
// reach JavaScript through goja's UncapFieldNameMapper: Go's JobID is job.jobID, AddTask is
// job.addTask, and so on.
//
// Run as a test file itself (node --test), it checks the stand-in against Flamenco's own test
// cases for crosspath and author.

"use strict";
const { randomUUID } = require("node:crypto");
const fs = require("node:fs");
const vm = require("node:vm");

// --- path: Flamenco's pkg/crosspath over Go's "path" package ---

const toSlash = (p) => p.replaceAll("\\", "/");

function goClean(p) {  // Go's path.Clean
    if (p === "") return ".";
    const rooted = p.startsWith("/");
    const parts = [];
    for (const part of p.split("/")) {
        if (part === "" || part === ".") continue;
        if (part === ".." && parts.length > 0 && parts[parts.length - 1] !== "..") parts.pop();
        else if (part !== ".." || !rooted) parts.push(part);
    }
    const cleaned = (rooted ? "/" : "") + parts.join("/");
    return cleaned === "" ? "." : cleaned;
}

function goExt(p) {  // Go's path.Ext
    for (let i = p.length - 1; i >= 0 && p[i] !== "/"; i--) {
        if (p[i] === ".") return p.slice(i);
    }
    return "";
}

function basename(p) {
    let slashed = toSlash(p);
    if (slashed === "") return ".";
    slashed = slashed.replace(/\/+$/, "");
    return slashed === "" ? "/" : slashed.slice(slashed.lastIndexOf("/") + 1);
}

function dirname(p) {
    if (p === "") return ".";
    const slashed = toSlash(p);
    const dir = slashed.slice(0, slashed.lastIndexOf("/") + 1);
    if (dir === "") return ".";
    return dir.length > 1 ? dir.slice(0, -1) : dir;
}

function join(...elements) {  // Go's path.Join: empty elements are left out
    const joined = elements.filter((e) => e !== "").join("/");
    return joined === "" ? "" : toSlash(goClean(joined));
}

function stem(p) {
    const base = basename(p);
    return base.slice(0, base.length - goExt(base).length);
}

const path = Object.freeze({ basename, dirname, join, stem });

// --- author: internal/manager/job_compilers/author.go ---

function Task(name, type) {
    name = String(name).trim();
    type = String(type).trim();
    if (name === "") throw new Error("author.Task(name, type): name is required");
    if (type === "") throw new Error("author.Task(name, type): type is required");
    const task = {
        uUID: randomUUID(), name, type, priority: 50, commands: [], dependencies: [],
        // The Go task keeps a copy of the command as it is when added.
        addCommand: (command) => { task.commands.push(structuredClone(command)); },
        addDependency: (dependency) => { task.dependencies.push(dependency); },
    };
    return Object.seal(task);
}

function Command(name, parameters, totalStepCount) {
    // Goja hands the parameters to Go as a map: a snapshot of plain data.
    return { name, parameters: structuredClone(parameters), totalStepCount: totalStepCount || 0 };
}

const author = Object.freeze({ Task, Command });

// --- globals: internal/manager/job_compilers/js_globals.go ---

function formatTimestampLocal(date) {  // Go layout "2006-01-02_150405", local time
    const two = (n) => String(n).padStart(2, "0");
    return `${date.getFullYear()}-${two(date.getMonth() + 1)}-${two(date.getDate())}_`
        + `${two(date.getHours())}${two(date.getMinutes())}${two(date.getSeconds())}`;
}

// --- the Manager's side: load a script, compile a submitted job ---

/** Loads a job compiler script the way the Manager does; returns its JOB_TYPE and compile(). */
function loadJobCompiler(filename) {
    const printed = [];
    const context = vm.createContext({
        print: (...args) => { printed.push(args.join(" ")); },
        alert: (...args) => { printed.push(args.join(" ")); },
        formatTimestampLocal, author, path,
    });
    // goja.Compile(filename, source, true): strict mode. Same line, so line numbers hold.
    new vm.Script(`"use strict"; ${fs.readFileSync(filename, "utf8")}`, { filename })
        .runInContext(context);
    const JOB_TYPE = vm.runInContext("JOB_TYPE", context);
    const compileJob = vm.runInContext("compileJob", context);

    /** Service.Compile: an AuthoredJob from a SubmittedJob, then compileJob(job). */
    function compile(submitted, created = new Date()) {
        const tasks = [];
        const job = Object.seal({
            jobID: randomUUID(), workerTagUUID: "", name: submitted.name, jobType: submitted.type,
            priority: submitted.priority ?? 50, status: "under-construction", created,
            settings: { ...submitted.settings }, metadata: { ...submitted.metadata },
            tasks,
            // Go's AuthoredJob.AddTask appends a copy of the task as it is when added.
            addTask: (task) => { tasks.push({ ...task, commands: [...task.commands] }); },
        });
        compileJob(job);
        return job;
    }
    return { JOB_TYPE, compile, printed };
}

module.exports = { loadJobCompiler, path, author, formatTimestampLocal };

// --- the stand-in checked against Flamenco's own tests (pkg/crosspath/crosspath_test.go,
//     internal/manager/job_compilers/author.go) ---

if (require.main === module) {
    const test = require("node:test");
    const assert = require("node:assert/strict");

    test("path.basename as crosspath.Base", () => {
        for (const [expect, input] of [
            [".", ""], ["justafile.txt", "justafile.txt"],
            ["with spaces.txt", "/Linux path/with spaces.txt"],
            ["awésom.tar.gz", "C:\\ünicode\\is\\awésom.tar.gz"],
            ["Resource with ext.ension",
             "\\\\?\\UNC\\ComputerName\\SharedFolder\\Resource with ext.ension"],
        ]) assert.equal(path.basename(input), expect, input);
    });

    test("path.dirname as crosspath.Dir", () => {
        for (const [expect, input] of [
            [".", ""], [".", "justafile.txt"], ["/", "/"], ["/", "/file-at-root"],
            ["C:", "C:\\file-at-root"], ["/Linux path", "/Linux path/with spaces.txt"],
            ["/Mixed path/with", "/Mixed path\\with/slash.txt"],
            ["C:/ünicode/is", "C:\\ünicode\\is\\awésom.tar.gz"],
            ["//SERVER/ünicode/is", "\\\\SERVER\\ünicode\\is\\awésom.tar.gz"],
            ["//?/UNC/ComputerName/SharedFolder",
             "\\\\?\\UNC\\ComputerName\\SharedFolder\\Resource"],
        ]) assert.equal(path.dirname(input), expect, input);
    });

    test("path.join as crosspath.Join", () => {
        for (const [expect, input] of [
            ["", []], ["", [""]], ["", ["", ""]], ["a/b", ["", "", "a", "", "b", ""]],
            ["/file-at-root", ["/", "file-at-root"]], ["C:/file-at-root", ["C:", "file-at-root"]],
            ["/Linux path/with spaces.txt", ["/Linux path", "with spaces.txt"]],
            ["C:/ünicode/is/awésom.tar.gz", ["C:\\ünicode", "is\\awésom.tar.gz"]],
            ["//SERVER/mount/dir/file.txt", ["\\\\SERVER", "mount", "dir", "file.txt"]],
            ["//?/UNC/ComputerName/SharedFolder/Resource",
             ["\\\\?\\UNC\\ComputerName", "SharedFolder\\Resource"]],
        ]) assert.equal(path.join(...input), expect, JSON.stringify(input));
    });

    test("path.stem as crosspath.Stem", () => {
        for (const [expect, input] of [
            ["", ""], ["stem", "stem.txt"], ["stem.tar", "stem.tar.gz"],
            ["file", "/path/to/file.txt"], ["file", "C:\\path\\to\\file.txt"],
            ["file", "C:\\path\\to/mixed/slashes/file.txt"],
            ["Resource with ext",
             "\\\\?\\UNC\\ComputerName\\SharedFolder\\Resource with ext.ension"],
        ]) assert.equal(path.stem(input), expect, input);
    });

    test("author.Task needs a name and a type; author.Command defaults to 0 steps", () => {
        assert.throws(() => author.Task(" ", "misc"), /name is required/);
        assert.throws(() => author.Task("echo", ""), /type is required/);
        const task = author.Task(" echo ", " misc ");
        assert.deepEqual([task.name, task.type, task.priority], ["echo", "misc", 50]);
        assert.equal(author.Command("echo", { message: "hi" }).totalStepCount, 0);
    });

    test("formatTimestampLocal uses Go's layout 2006-01-02_150405 in local time", () => {
        assert.equal(formatTimestampLocal(new Date(2006, 0, 2, 15, 4, 5)), "2006-01-02_150405");
    });
}
