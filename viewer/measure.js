// SPDX-License-Identifier: GPL-3.0-or-later
//
// What a measured view hands back (viewer.js's ?measure=1, and the tests' Babylon.js page):
// float rows top first, as base64 in the page's <pre id="measure"> JSON.

export function base64(typedArray) {
    const bytes = new Uint8Array(typedArray.buffer, typedArray.byteOffset, typedArray.byteLength);
    const chunks = [];
    for (let start = 0; start < bytes.length; start += 0x8000) {
        chunks.push(String.fromCharCode.apply(null, bytes.subarray(start, start + 0x8000)));
    }
    return btoa(chunks.join(""));
}

// The first `channels` channels of RGBA pixels read bottom row first, top row first.
export function topRowsFirst(rgba, width, height, channels) {
    const rows = new Float32Array(width * height * channels);
    for (let y = 0; y < height; y++) {
        for (let x = 0; x < width; x++) {
            const from = ((height - 1 - y) * width + x) * 4;
            const to = (y * width + x) * channels;
            for (let c = 0; c < channels; c++) rows[to + c] = rgba[from + c];
        }
    }
    return rows;
}
