// SPDX-License-Identifier: GPL-3.0-or-later
//
// The luxel-bake job type, compiled as Flamenco Manager compiles it (flamenco.js), checked
// against what Flamenco documents: the setting schema (AvailableJobSetting in the Manager's
// OpenAPI), the blender-render command's parameters and how the Worker turns them into
// `{exe} {exeArgs} {argsBefore} {blendfile} {args}`, and against Luxel's real command line
// (addon/cli.py).

"use strict";
const test = require("node:test");
const assert = require("node:assert/strict");
const fs = require("node:fs");
const nodePath = require("node:path");
const { loadJobCompiler } = require("./flamenco.js");

const ROOT = nodePath.resolve(__dirname, "..", "..");
const { JOB_TYPE, compile } = loadJobCompiler(nodePath.join(ROOT, "farm", "luxel_bake.js"));

// A job created at this local time has its folder named "2006-01-02_150405-<job ID>".
const CREATED = new Date(2006, 0, 2, 15, 4, 5);
const BASE = { output_root: "/render/bakes", density: 20, threshold: 0.01 };

function submit(settings, created = CREATED) {
    return compile({ name: "overnight", type: "luxel-bake", priority: 50, settings }, created);
}

function jobDir(job) {
    return `/render/bakes/2006-01-02_150405-${job.jobID}`;
}

// The Worker's blender-render: `{exe} {exeArgs} {argsBefore} {blendfile} {args}`, exeArgs split
// like a shell would; {blender} and {blenderArgs} as the Manager's default variables set them.
function commandLine(parameters) {
    const expand = (s) => s.replace("{blender}", "blender").replace("{blenderArgs}", "-b -y");
    return [expand(parameters.exe), ...expand(parameters.exeArgs).split(/\s+/).filter(Boolean),
            ...parameters.argsBefore, parameters.blendfile, ...parameters.args];
}

// Luxel's command line, read from addon/cli.py (the command, the subcommand and its own
// options) and native/settings.py (the options of the solver's settings, add_options).
const CLI = fs.readFileSync(nodePath.join(ROOT, "addon", "cli.py"), "utf8");
const SETTINGS = fs.readFileSync(nodePath.join(ROOT, "native", "settings.py"), "utf8");
const BAKE_OPTIONS = new Set([
    ...[...CLI.matchAll(/\b(?:bake|saving)\.add_argument\("(--[\w-]+)"/g)].map((m) => m[1]),
    ...[...SETTINGS.matchAll(/\boption="(--[\w-]+)"/g)].map((m) => m[1]),
]);

// A setting as native/settings.py declares it: the text from its Setting(name="...") on.
function declared(name) {
    const start = SETTINGS.indexOf(`Setting(name="${name}"`);
    assert.ok(start >= 0, `native/settings.py declares no ${name}`);
    const text = SETTINGS.slice(start, SETTINGS.indexOf("Setting(name=", start + 1));
    const number = (key) => {
        const found = text.match(new RegExp(`\\b${key}=([\\d.]+)`));
        return found ? Number(found[1]) : undefined;
    };
    return { option: text.match(/\boption="(--[\w-]+)"/)[1], default: number("default"),
             minimum: number("minimum"), maximum: number("maximum"),
             softMaximum: number("soft_maximum"), digits: number("digits") };
}

test("Luxel's command line has the names the job uses", () => {
    assert.match(CLI, /register_cli_command\("luxel", execute\)/);
    assert.match(CLI, /add_parser\("bake"/);
    assert.match(CLI, /\badd_options\(bake\)/);
    assert.deepEqual([declared("texel_density").option, declared("threshold").option],
                     ["--density", "--threshold"]);
    for (const option of ["--density", "--threshold", "--output", "--save-as"]) {
        assert.ok(BAKE_OPTIONS.has(option), `luxel bake has no ${option}`);
    }
    assert.match(CLI, /"--save-as", metavar="FILE.blend"/);  // it takes the file's path
});

test("JOB_TYPE: label and settings as Flamenco's AvailableJobSetting allows", () => {
    assert.equal(JOB_TYPE.label, "Luxel Bake");
    const byKey = Object.fromEntries(JOB_TYPE.settings.map((s) => [s.key, s]));
    for (const setting of JOB_TYPE.settings) {
        assert.ok(["string", "int32", "float", "bool"].includes(setting.type), setting.key);
        if (setting.subtype !== undefined) {
            assert.ok(["file_path", "dir_path", "file_name", "hashed_file_path"]
                .includes(setting.subtype), setting.key);
        }
        if (setting.visible !== undefined) {
            assert.ok(["visible", "hidden", "submission", "web"].includes(setting.visible));
        }
    }
    assert.deepEqual(
        Object.fromEntries(["blendfiles", "output_root", "density", "threshold", "save"]
            .map((key) => [key, [byKey[key].type, byKey[key].required === true]])),
        { blendfiles: ["string", true], output_root: ["string", true], density: ["float", true],
          threshold: ["float", true], save: ["bool", false] });
    assert.equal(byKey.output_root.subtype, "dir_path");
    // The form starts at Luxel's own defaults, within its ranges (native/settings.py).
    const density = declared("texel_density");
    const threshold = declared("threshold");
    assert.deepEqual([byKey.density.default, byKey.threshold.default, byKey.save.default],
                     [density.default, threshold.default, false]);
    // (Copied out of the script's realm, whose objects have another prototype.)
    assert.deepEqual({ ...byKey.density.propargs }, { min: density.minimum,
                                                      soft_max: density.softMaximum });
    assert.deepEqual({ ...byKey.threshold.propargs }, { min: threshold.minimum,
                                                        max: threshold.maximum,
                                                        precision: threshold.digits });
    // The add-on fills a setting named "blendfile" with its own packed copy of the open file.
    assert.equal(byKey.blendfile, undefined);
});

test("one scene: one luxel task running blender-render with the bake last", () => {
    const job = submit({ ...BASE, blendfiles: "/projects/cornell_box.blend" });
    assert.equal(job.tasks.length, 1);
    const [task] = job.tasks;
    assert.equal(task.type, "luxel");
    assert.equal(task.name, "bake-1-cornell_box");
    assert.equal(task.commands.length, 1);
    assert.equal(task.commands[0].name, "blender-render");
    assert.deepEqual(task.commands[0].parameters, {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        argsBefore: [],
        blendfile: "/projects/cornell_box.blend",
        args: ["--command", "luxel", "bake", "--density", "20", "--threshold", "0.01",
               "--output", `${jobDir(job)}/1-cornell_box`],
    });
    assert.deepEqual(commandLine(task.commands[0].parameters), [
        "blender", "-b", "-y", "/projects/cornell_box.blend", "--command", "luxel", "bake",
        "--density", "20", "--threshold", "0.01", "--output", `${jobDir(job)}/1-cornell_box`]);
    assert.equal(job.settings.job_output_dir, jobDir(job));
});

test("several scenes: a task and an output folder each, in the order listed", () => {
    const job = submit({
        ...BASE, density: 7.5, threshold: 0.05,
        blendfiles: " /shots/a/scene.blend ; /shots/b/scene.blend;;R:\\shots\\Office.BLEND; ",
    });
    assert.deepEqual(job.tasks.map((t) => [t.name, t.type]), [
        ["bake-1-scene", "luxel"], ["bake-2-scene", "luxel"], ["bake-3-Office", "luxel"]]);
    const parameters = job.tasks.map((t) => t.commands[0].parameters);
    // The blend file reaches the Worker as given (Flamenco's own test keeps backslashes too).
    assert.deepEqual(parameters.map((p) => p.blendfile),
                     ["/shots/a/scene.blend", "/shots/b/scene.blend", "R:\\shots\\Office.BLEND"]);
    for (const p of parameters) {
        assert.deepEqual(p.args.slice(0, 7),
                         ["--command", "luxel", "bake", "--density", "7.5", "--threshold", "0.05"]);
    }
    const outputs = parameters.map((p) => p.args[p.args.indexOf("--output") + 1]);
    assert.deepEqual(outputs, [`${jobDir(job)}/1-scene`, `${jobDir(job)}/2-scene`,
                               `${jobDir(job)}/3-Office`]);
});

test("ten scenes or more: folder numbers padded, so they sort", () => {
    const files = Array.from({ length: 12 }, (_, i) => `/s/scene${i}.blend`).join(";");
    const job = submit({ ...BASE, blendfiles: files });
    assert.equal(job.tasks.length, 12);
    assert.equal(job.tasks[0].name, "bake-01-scene0");
    assert.equal(job.tasks[11].name, "bake-12-scene11");
});

test("--command comes after the .blend file and every Blender option, Luxel's after it", () => {
    for (const save of [false, true]) {
        const job = submit({ ...BASE, save, blendfiles: "/p/a.blend;/p/b.blend" });
        for (const task of job.tasks) {
            const line = commandLine(task.commands[0].parameters);
            const at = line.indexOf("--command");
            assert.ok(at > line.indexOf(task.commands[0].parameters.blendfile));
            assert.equal(line.indexOf("--command", at + 1), -1);
            assert.deepEqual(line.slice(at + 1, at + 3), ["luxel", "bake"]);
            const options = line.slice(at + 3).filter((arg) => arg.startsWith("--"));
            assert.deepEqual(options.filter((o) => !BAKE_OPTIONS.has(o)), []);
            assert.ok(task.commands[0].parameters.args.every((arg) => typeof arg === "string"));
        }
    }
});

test("--save-as only when save is on: a new file in the scene's folder, the listed one only read",
     () => {
    for (const save of [undefined, false]) {
        const args = submit({ ...BASE, save, blendfiles: "/p/a.blend" })
            .tasks[0].commands[0].parameters.args;
        assert.ok(!args.includes("--save-as") && !args.includes("--save"), `save ${save}`);
        assert.equal(args[0], "--command");
    }
    const job = submit({ ...BASE, save: true, blendfiles: "/p/a.blend;R:\\shots\\Office.BLEND" });
    const names = ["1-a/a.blend", "2-Office/Office.BLEND"];
    for (const [task, name] of job.tasks.map((t, i) => [t, names[i]])) {
        const args = task.commands[0].parameters.args;
        assert.equal(args[0], "--command");  // no Python run before the bake
        assert.deepEqual(args.slice(-2), ["--save-as", `${jobDir(job)}/${name}`]);
        assert.ok(!args.includes("--save"));
        const output = args[args.indexOf("--output") + 1];
        assert.equal(nodePath.posix.dirname(args[args.length - 1]), output);
    }
});

test("two jobs of the same files, even created the same second, write disjoint folders", () => {
    const settings = { ...BASE, save: true, blendfiles: "/p/a.blend;/p/b.blend" };
    const outputs = [submit(settings), submit(settings)].flatMap((job) => job.tasks.map((t) => {
        const args = t.commands[0].parameters.args;
        return args[args.indexOf("--output") + 1];
    }));
    assert.equal(new Set(outputs).size, 4);
    for (const a of outputs) {
        for (const b of outputs) {
            assert.ok(a === b || !b.startsWith(`${a}/`), `${b} inside ${a}`);
        }
    }
});

test("density and threshold: taken at the ends of Luxel's ranges, refused just beyond", () => {
    const density = declared("texel_density");
    const threshold = declared("threshold");
    for (const change of [{ density: density.minimum }, { threshold: threshold.minimum },
                          { threshold: threshold.maximum }]) {
        assert.equal(submit({ ...BASE, blendfiles: "/p/a.blend", ...change }).tasks.length, 1);
    }
    for (const [change, key] of [[{ density: density.minimum - 1e-9 }, "density"],
                                 [{ threshold: threshold.minimum - 1e-9 }, "threshold"],
                                 [{ threshold: threshold.maximum + 1e-9 }, "threshold"]]) {
        assert.throws(() => submit({ ...BASE, blendfiles: "/p/a.blend", ...change }),
                      (error) => error.message.includes(`"${key}"`), JSON.stringify(change));
    }
});

test("refused: a missing or invalid setting, named in the error, and no task made", () => {
    const cases = [
        [{ blendfiles: undefined }, "blendfiles", /missing/],
        [{ blendfiles: "" }, "blendfiles", /missing/],
        [{ blendfiles: " ; ;" }, "blendfiles", /missing/],
        [{ blendfiles: 3 }, "blendfiles", /missing/],
        [{ blendfiles: "/p/a.blend, /p/b.blend" }, "blendfiles", /not a \.blend file/],
        [{ blendfiles: "/p/a.blend;/p/a.blend1" }, "blendfiles", /not a \.blend file/],
        [{ blendfiles: "/p/a.blend;/p/b.blend;/p/a.blend" }, "blendfiles", /twice/],
        [{ blendfiles: "C:\\p\\a.blend;C:/p/a.blend" }, "blendfiles", /twice/],
        [{ output_root: undefined }, "output_root", /missing/],
        [{ output_root: "  " }, "output_root", /missing/],
        [{ density: undefined }, "density", /missing/],
        [{ density: "20" }, "density", /must be a number of at least 0.01 texels per metre/],
        [{ density: 0 }, "density", /must be a number of at least 0.01/],
        [{ density: -4 }, "density", /must be a number of at least 0.01/],
        [{ threshold: null }, "threshold", /missing/],
        [{ threshold: 1 }, "threshold", /must be a number from 0 to 0.99/],
        [{ threshold: -0.01 }, "threshold", /must be a number from 0 to 0.99/],
        [{ threshold: "0.01" }, "threshold", /must be a number from 0 to 0.99/],
        [{ save: "yes" }, "save", /must be true or false/],
    ];
    for (const [change, key, problem] of cases) {
        const settings = { ...BASE, blendfiles: "/p/a.blend;/p/b.blend", ...change };
        let job = null;
        assert.throws(() => { job = submit(settings); }, (error) => {
            // An Error of the script's own realm, not a thrown string.
            assert.equal(Object.prototype.toString.call(error), "[object Error]");
            assert.ok(error.message.includes(`"${key}"`), error.message);
            assert.match(error.message, problem);
            return true;
        }, JSON.stringify(change));
        assert.equal(job, null);
    }
});
