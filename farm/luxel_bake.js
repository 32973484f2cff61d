// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco job type "luxel-bake" (the Manager names a job type after its script's file name,
// underscores turned into dashes). It bakes Luxel lightmaps for one or more .blend files: one
// task per file, since a radiosity solve covers a whole scene and there are no frames to split.
//
// Each task runs, on a Worker whose task types include "luxel":
//   {blender} {blenderArgs} FILE --command luxel bake --density D --threshold T --output DIR
// DIR is OUTPUT_ROOT/<job's creation time>-<job ID>/<n>-<file's stem>: a folder of its own for
// every job and every scene. With "save" on, --save-as DIR/<file's name> saves the baked
// scene there as a new file: the listed .blend files themselves are only ever read.

const SEPARATOR = ";";
const TASK_TYPE = "luxel";
// Luxel's ranges of its texel_density and threshold settings (native/settings.py; the tests
// check these against it), so that a job Luxel would refuse is refused when submitted.
const DENSITY_MIN = 0.01;
const DENSITY_SOFT_MAX = 1000.0;
const THRESHOLD_MIN = 0.0;
const THRESHOLD_MAX = 0.99;

const JOB_TYPE = {
    label: "Luxel Bake",
    description: "Bake Luxel radiosity lightmaps for one or more .blend files, one task per file",
    settings: [
        { key: "blendfiles", type: "string", required: true, eval: "bpy.data.filepath",
          description: `The .blend files to bake, separated by "${SEPARATOR}", `
              + "as paths the Workers can open" },
        { key: "output_root", type: "string", subtype: "dir_path", required: true,
          description: "Folder for the lightmaps; every job writes into a new subfolder of it" },
        { key: "density", type: "float", required: true, default: 20.0,
          propargs: { min: DENSITY_MIN, soft_max: DENSITY_SOFT_MAX },
          description: "Lightmap texels per metre of surface (luxel bake --density)" },
        { key: "threshold", type: "float", required: true, default: 0.01,
          propargs: { min: THRESHOLD_MIN, max: THRESHOLD_MAX, precision: 4 },
          description: "Stop when this fraction of the emitted power is unshot (--threshold)" },
        { key: "save", type: "bool", default: false,
          description: "Also save each .blend with its lightmaps, as a copy in its output folder" },
        { key: "job_output_dir", type: "string", subtype: "dir_path", visible: "web",
          description: "Where this job writes: one subfolder per .blend file" },
    ],
};

function compileJob(job) {
    const settings = job.settings;
    const blendfiles = blendfileList(settings.blendfiles);
    const outputRoot = requiredFolder(settings, "output_root");
    const density = requiredNumber(settings, "density", (d) => d >= DENSITY_MIN,
                                   `a number of at least ${DENSITY_MIN} texels per metre, `
                                   + "e.g. 20");
    const threshold = requiredNumber(settings, "threshold",
                                     (t) => t >= THRESHOLD_MIN && t <= THRESHOLD_MAX,
                                     `a number from ${THRESHOLD_MIN} to ${THRESHOLD_MAX}, `
                                     + "e.g. 0.01");
    const save = settings.save === undefined ? false : settings.save;
    if (typeof save !== "boolean") {
        refuse("save", "must be true or false");
    }

    // The job ID makes the folder unique to this job, the time makes the folders sort.
    const jobDir = path.join(outputRoot, `${formatTimestampLocal(job.created)}-${job.jobID}`);
    settings.job_output_dir = jobDir;
    print(`Luxel bake: ${blendfiles.length} scene(s) into ${jobDir}`);

    const digits = String(blendfiles.length).length;
    blendfiles.forEach((blendfile, index) => {
        const folder = `${String(index + 1).padStart(digits, "0")}-${path.stem(blendfile)}`;
        const task = author.Task(`bake-${folder}`, TASK_TYPE);
        task.addCommand(author.Command("blender-render", {
            exe: "{blender}",
            exeArgs: "{blenderArgs}",
            argsBefore: [],
            blendfile: blendfile,
            // --command takes all that follows it. --save-as writes a new file in the
            // scene's folder: the listed .blend is only read.
            args: ["--command", "luxel", "bake",
                   "--density", String(density), "--threshold", String(threshold),
                   "--output", path.join(jobDir, folder),
                   ...(save ? ["--save-as", path.join(jobDir, folder, path.basename(blendfile))]
                       : [])],
        }));
        job.addTask(task);
    });
}

function refuse(key, problem) {
    throw new Error(`luxel-bake: the setting "${key}" ${problem}`);
}

function blendfileList(value) {
    const files = (typeof value === "string" ? value.split(SEPARATOR) : [])
        .map((file) => file.trim())
        .filter((file) => file !== "");
    if (files.length === 0) {
        refuse("blendfiles",
               `is missing: list one or more .blend files separated by "${SEPARATOR}"`);
    }
    const seen = new Set();
    for (const file of files) {
        if (!/\.blend$/i.test(file) || /\.blend\s*,/i.test(file)) {
            refuse("blendfiles", `names "${file}", which is not a .blend file `
                   + `(separate the files with "${SEPARATOR}")`);
        }
        const key = file.replaceAll("\\", "/");
        if (seen.has(key)) {
            refuse("blendfiles", `names "${file}" twice`);
        }
        seen.add(key);
    }
    return files;
}

function requiredFolder(settings, key) {
    const value = settings[key];
    if (typeof value !== "string" || value.trim() === "") {
        refuse(key, "is missing: give a folder the Workers can write to");
    }
    return value.trim();
}

function requiredNumber(settings, key, isValid, expected) {
    const value = settings[key];
    if (value === undefined || value === null) {
        refuse(key, `is missing: give ${expected}`);
    }
    if (typeof value !== "number" || !Number.isFinite(value) || !isValid(value)) {
        refuse(key, `must be ${expected}, not ${JSON.stringify(value)}`);
    }
    return value;
}
