/* A haptic loop through the corofem C API.
 *
 *   haptic_loop [MESH.tetmesh|box] [STEPS] [--probe [--friction] [--coupling]] [--rt]
 *   haptic_loop --help
 *
 * Builds a scene in a static buffer (no allocation anywhere), fixes part of
 * it, grabs another part with the haptic tool, moves the tool along a fixed
 * path for STEPS steps of 1 ms and prints the final tool force and a hash of
 * the state. The Rust test capi/tests/haptic_loop.rs builds the same scene
 * through the Rust API and checks that the hashes are equal; .ci/capi.sh
 * runs this program on the host and, cross-compiled, on a Cortex-M4F in QEMU.
 *
 * On the box it also binds an embedded surface (a tube around the beam),
 * checks it at rest and prints where its tip ring ends up; a library built
 * without the feature `surface` (the Cortex-M4F's) says so instead.
 *
 * Scenes (all must match capi/tests/haptic_loop.rs exactly):
 *   box   (default) a 10 cm × 2 cm × 2 cm beam, 99 nodes / 240 tets,
 *         fixed at x = 0, grabbed at x = 10 cm, pulled down and back.
 *   MESH  SOFA's liver (sofa_liver.tetmesh) scaled by 0.03 to metres,
 *         fixed at nodes 3, 39, 64, grabbed at its tip, pulled out and back.
 *         Any mesh in SOFA's liver units is scaled so; with --probe, the
 *         finer liver (liver_ftw_3k.tetmesh, 729 nodes / 2772 tets, edges
 *         of about 1 cm) is the one whose surface a fingertip resolves.
 *
 * --probe: instead of the tool, a sphere of radius 1 cm (a fingertip)
 * presses on the body from above, the body held by a tray (its nodes
 * within 3 cm of its lowest fixed; the box's bottom face), without gravity
 * (this soft liver, E = 5 kPa, would slump under its weight on a tray of
 * 15 nodes): only the probe loads it. On the liver it presses over the
 * topmost node (+y), on the box over node 84 (+z; x = 7 cm, on the top
 * face's centre line). It starts 2 mm above that node, presses in 0.3 s
 * to 1 cm below it, slides 15 mm along +x in 0.5 s, rises back in 0.3 s
 * and returns above its start in 0.1 s: a cycle of 1.2 s, repeated. The
 * program prints the probe's final force, its largest push, the support
 * force and the hash.
 * --friction gives the probe Coulomb friction (static 0.6, kinetic 0.4), so
 * that the slide drags the surface along. A library built without the
 * feature `probe` (the Cortex-M4F's) says so and stops.
 * --coupling makes the path the haptic device's and the probe its proxy,
 * joined by a virtual coupling (spring 1000 N/m, damper 2 N s/m, proxy of
 * 10 g: the README's guide for a device of 1 N s/m at 1 kHz): each period
 * drives the coupling from the device's position and its velocity (the
 * difference of its positions over the period, as a device measures it),
 * steps, and renders the coupling's force instead of the probe's. The
 * program also prints the rendered force and its largest magnitude.
 *
 * --rt paces the loop at 1 kHz with absolute deadlines (POSIX hosts:
 * mlockall, buffers touched first, on Linux 1 ns timer slack, the last
 * 50 us spun) and reports the per-step time's median (p50), p99, p99.9 and
 * maximum and the deadline misses; without it the loop runs flat out and
 * reports the same percentiles.
 *
 * Build (host, at the repository root; capi is a member of the root
 * workspace, so the library lands in the root's target/, or in
 * $CARGO_TARGET_DIR when that is set):
 *   cargo build --release -p corofem-capi
 *   cc -std=c11 -O2 -ffp-contract=off -Icapi/include capi/examples/haptic_loop.c \
 *      target/release/libcorofem_capi.a -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc
 * Cortex-M4F: see .ci/capi.sh (-DCOROFEM_BARE_METAL, cortex-m4f/startup.c
 * and link.ld). -ffp-contract=off: the tool path must round exactly as in
 * Rust (no fused multiply-add, which the M4F has), or the hashes differ.
 */
#if !defined(COROFEM_BARE_METAL)
#define _POSIX_C_SOURCE 200809L /* clock_gettime, clock_nanosleep */
#endif
#include <inttypes.h>
#include <math.h> /* sqrt */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corofem.h"

#if defined(COROFEM_BARE_METAL)
#define HAVE_FILES 0
#define HAVE_CLOCK 0
#define MAX_NODES 512
#define MAX_TETS 2048
#else
#define HAVE_FILES 1
#define HAVE_CLOCK 1
#define MAX_NODES 4096
#define MAX_TETS 16384
#include <sys/mman.h> /* mlockall */
#include <time.h>
#if defined(__linux__)
#include <sys/prctl.h> /* PR_SET_TIMERSLACK */
#endif
#endif

/* Static storage: the mesh arrays and the scene arena. */
static float nodes[MAX_NODES * 3];
static uint32_t tets[MAX_TETS * 4];
static float positions[MAX_NODES * 3];
static uint32_t on_tray[MAX_NODES]; /* the probe scene's fixed nodes */
/* Large enough for MAX_NODES / MAX_TETS with every feature (checked below):
 * per node 136 B of state and scratch (with the ground and friction), 32 B
 * of grab and load slots and 32 B of preconditioner node block; per
 * tetrahedron at most 136 B; and the
 * two-level preconditioner's aggregates: on the host at most 64 of 176 B
 * for 4 096 nodes, and the 385 rows of 48 slots of 32 B of their coarse
 * solve; none on bare metal, whose library is built without the
 * preconditioner (corofem_scene_bytes gives the exact need). */
#if defined(COROFEM_BARE_METAL)
#define AGGREGATE_BYTES 0
#else
#define AGGREGATE_BYTES (64 * 176 + 385 * 48 * 32)
#endif
static unsigned char arena[MAX_NODES * 200 + MAX_TETS * 136 + AGGREGATE_BYTES + 512];

/* The probe scene's one probe: a set of probes lives in a buffer of its
 * own, like the scene (100 B per probe and a header; corofem_probes_bytes
 * gives the exact need). */
static unsigned char probe_buffer[256];
#define PROBE_RADIUS 0.01f
#define PROBE_DEPTH 0.01f

/* An embedded surface for the box: an open tube of radius 1.2 cm around the
 * beam's axis (12 vertices on each of 11 rings, 1 cm apart), partly inside
 * the 2 cm square section and partly outside it, bound once and moved with
 * the beam. */
#define SKIN_RING 12
#define SKIN_RINGS 11
#define SKIN_V (SKIN_RING * SKIN_RINGS)
#define SKIN_T (2 * SKIN_RING * (SKIN_RINGS - 1))
static float skin_xyz[SKIN_V * 3];
static uint32_t skin_tris[SKIN_T * 3];
static float skin_out[SKIN_V * 3];
static float skin_normals[SKIN_V * 3];
/* The binding buffer: 44 B per vertex, 12 B per triangle and a header
 * (corofem_surface_bytes gives the exact need); the scratch is needed only
 * while binding. */
static unsigned char skin_buffer[SKIN_V * 44 + SKIN_T * 12 + 128];
static uint32_t skin_scratch[3 * SKIN_V + 1];
static corofem_surface *skin = NULL;

#define CHECK(call)                                                              \
    do {                                                                         \
        corofem_status s_ = (call);                                              \
        if (s_ != COROFEM_STATUS_OK) {                                           \
            printf("error: %s -> %d (%s)\n", #call, (int)s_, corofem_status_str(s_)); \
            return 1;                                                            \
        }                                                                        \
    } while (0)

#if HAVE_FILES
/* Reads a `tetmesh 1` file, scaling coordinates (double, as the Rust reader
 * does, then rounded to float). Returns 0 on success. */
static int read_tetmesh(const char *path, double scale, size_t *n, size_t *t) {
    FILE *f = fopen(path, "r");
    unsigned version = 0;
    if (!f) {
        printf("error: cannot open %s\n", path);
        return 1;
    }
    unsigned long nn = 0, tt = 0;
    if (fscanf(f, "tetmesh %u %lu %lu", &version, &nn, &tt) != 3 || version != 1 ||
        nn > MAX_NODES || tt > MAX_TETS) {
        printf("error: %s: bad header or too large\n", path);
        fclose(f);
        return 1;
    }
    *n = nn, *t = tt;
    for (size_t i = 0; i < 3 * *n; i++) {
        double x;
        if (fscanf(f, "%lf", &x) != 1) {
            fclose(f);
            return 1;
        }
        nodes[i] = (float)(x * scale);
    }
    for (size_t i = 0; i < 4 * *t; i++) {
        if (fscanf(f, "%" SCNu32, &tets[i]) != 1) {
            fclose(f);
            return 1;
        }
    }
    fclose(f);
    return 0;
}
#endif

#if HAVE_CLOCK
static int64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static int cmp_i64(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static int64_t step_ns[100000];

/* The nearest-rank `per_mille` / 10 percentile of `n` sorted values. */
static int64_t pct(const int64_t *sorted, uint32_t n, uint32_t per_mille) {
    uint64_t k = ((uint64_t)n * per_mille + 999) / 1000; /* ceil(n p) */
    if (k < 1) k = 1;
    return sorted[k - 1];
}
#endif

/* The tool path: a triangle wave 0 → 1 → 0 over each second (1000 steps). */
static float triangle(uint32_t step) {
    float a = (float)(step % 1000u) / 1000.0f;
    return a < 0.5f ? 2.0f * a : 2.0f - 2.0f * a;
}

/* The probe's centre at the end of step `k` (1-based), from its start
 * `c0` to its deepest point `b` and back, in cycles of 1200 steps: to `b`
 * over steps 1..300, 15 mm along +x over 301..800, back up to `c0` (15 mm
 * along) over 801..1100, back over `c0` over 1101..1200. Plain float
 * operations in this order, as capi/tests/haptic_loop.rs computes them. */
static void probe_path(const float c0[3], const float b[3], uint32_t step, float out[3]) {
    const float slide = 0.015f;
    const uint32_t k = (step - 1u) % 1200u + 1u;
    float s, side; /* s: 0 at c0, 1 at b */
    if (k <= 300u) {
        s = (float)k / 300.0f, side = 0.0f;
    } else if (k <= 800u) {
        s = 1.0f, side = slide * ((float)(k - 300u) / 500.0f);
    } else if (k <= 1100u) {
        s = (float)(1100u - k) / 300.0f, side = slide;
    } else {
        s = 0.0f, side = slide * ((float)(1200u - k) / 100.0f);
    }
    for (int c = 0; c < 3; c++) out[c] = c0[c] + (b[c] - c0[c]) * s;
    out[0] = out[0] + side;
}

/* Binds the tube to the box scene and checks it at rest: every vertex where
 * it was given, every normal of unit length. Returns 0 on success, 1 on
 * error, 2 if the library was built without surfaces. */
static int bind_skin(corofem_scene *scene) {
    size_t bytes = 0, scratch_len = 0, where = 0;
    corofem_bind_stats found;
    corofem_status st = corofem_surface_bytes(SKIN_V, SKIN_T, &bytes, &scratch_len);
    if (st == COROFEM_STATUS_UNSUPPORTED) return 2;
    CHECK(st);
    if (bytes > sizeof skin_buffer || scratch_len > sizeof skin_scratch / sizeof skin_scratch[0]) {
        printf("error: the surface needs %lu bytes and %lu of scratch\n", (unsigned long)bytes,
               (unsigned long)scratch_len);
        return 1;
    }
    /* cos(15 + 30 k degrees), as literals: no libm needed. The vertices at
     * 45 degrees are inside the beam, the others up to 1.6 mm outside. */
    static const float c12[SKIN_RING] = {0.9659258f,  0.7071068f,  0.2588190f,  -0.2588190f,
                                         -0.7071068f, -0.9659258f, -0.9659258f, -0.7071068f,
                                         -0.2588190f, 0.2588190f,  0.7071068f,  0.9659258f};
    for (uint32_t r = 0; r < SKIN_RINGS; r++) {
        for (uint32_t k = 0; k < SKIN_RING; k++) {
            float *p = &skin_xyz[3 * (r * SKIN_RING + k)];
            p[0] = 0.01f * (float)r;
            p[1] = 0.01f + 0.012f * c12[k];
            p[2] = 0.01f + 0.012f * c12[(k + 9) % SKIN_RING]; /* sin a = cos(a - 90 degrees) */
        }
    }
    for (uint32_t r = 0; r + 1 < SKIN_RINGS; r++) {
        for (uint32_t k = 0; k < SKIN_RING; k++) {
            uint32_t a = r * SKIN_RING + k, b = r * SKIN_RING + (k + 1) % SKIN_RING;
            uint32_t *t = &skin_tris[6 * (r * SKIN_RING + k)];
            /* Counter-clockwise seen from outside: outward normals. */
            t[0] = a, t[1] = b, t[2] = a + SKIN_RING;
            t[3] = b, t[4] = b + SKIN_RING, t[5] = a + SKIN_RING;
        }
    }
    st = corofem_bind_surface(scene, skin_xyz, SKIN_V, skin_tris, SKIN_T, 0.003f, skin_buffer,
                              sizeof skin_buffer, skin_scratch, scratch_len, &skin, &found, &where);
    if (st != COROFEM_STATUS_OK) {
        printf("error: binding the surface -> %d (%s) at %lu\n", (int)st, corofem_status_str(st),
               (unsigned long)where);
        return 1;
    }
    CHECK(corofem_update_surface(scene, skin, skin_out, 3 * SKIN_V, skin_normals, 3 * SKIN_V));
    for (size_t i = 0; i < 3 * SKIN_V; i += 3) {
        const float *n = &skin_normals[i];
        float len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        if (memcmp(&skin_out[i], &skin_xyz[i], sizeof(float[3])) != 0 || len2 < 0.9999f ||
            len2 > 1.0001f) {
            printf("error: surface vertex %lu at rest\n", (unsigned long)(i / 3));
            return 1;
        }
    }
    printf("surface: %u vertices, %u triangles, %lu bytes (+%lu while binding): %lu inside, "
           "%lu outside, at most %.4f m out\n",
           (unsigned)SKIN_V, (unsigned)SKIN_T, (unsigned long)bytes,
           (unsigned long)(scratch_len * sizeof(uint32_t)), (unsigned long)found.inside,
           (unsigned long)found.outside, (double)found.max_distance);
    return 0;
}

static const char USAGE[] =
    "usage: haptic_loop [MESH.tetmesh|box] [STEPS] [--probe [--friction] [--coupling]] [--rt]\n"
    "\n"
    "Runs the haptic loop of the corofem C API example for STEPS steps of 1 ms\n"
    "(default 2000) on the built-in 10 x 2 x 2 cm beam (box, the default) or on\n"
    "a tetmesh file (SOFA's liver, scaled by 0.03 to metres), and prints the\n"
    "final tool force and a hash of the state.\n"
    "  --probe     press a 1 cm sphere 1 cm into the body from above, slide it, lift\n"
    "              it, instead of pulling with the tool; print the probe's force\n"
    "  --friction  with --probe: Coulomb friction between probe and body\n"
    "              (static 0.6, kinetic 0.4)\n"
    "  --coupling  with --probe: the path is the device's, the probe its proxy\n"
    "              through a virtual coupling (1000 N/m, 2 N s/m, 10 g); render\n"
    "              the coupling's force\n"
    "  --rt        pace the loop at 1 kHz and report deadline misses\n"
    "  -h, --help  print this help\n";

int main(int argc, char **argv) {
    /* Options first, anywhere: anything else that starts with '-' is not a
     * mesh file; the others are the mesh and the step count, in order. */
    const char *mesh = "box", *steps_arg = NULL;
    int rt = 0, with_probe = 0, with_friction = 0, with_coupling = 0, positional = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fputs(USAGE, stdout);
            return 0;
        } else if (strcmp(argv[i], "--rt") == 0) {
            rt = 1;
        } else if (strcmp(argv[i], "--probe") == 0) {
            with_probe = 1;
        } else if (strcmp(argv[i], "--friction") == 0) {
            with_friction = 1;
        } else if (strcmp(argv[i], "--coupling") == 0) {
            with_coupling = 1;
        } else if (argv[i][0] == '-') {
            printf("error: unknown option %s\n%s", argv[i], USAGE);
            return 2;
        } else if (positional == 0) {
            mesh = argv[i], positional = 1;
        } else if (positional == 1) {
            steps_arg = argv[i], positional = 2;
        } else {
            printf("error: unexpected argument %s\n%s", argv[i], USAGE);
            return 2;
        }
    }
    if ((with_friction || with_coupling) && !with_probe) {
        printf("error: --friction and --coupling need --probe\n%s", USAGE);
        return 2;
    }
    uint32_t steps = steps_arg ? (uint32_t)strtoul(steps_arg, NULL, 10) : 2000;
    (void)rt; /* unused without a clock */
    int is_box = strcmp(mesh, "box") == 0;
    size_t n = 0, t = 0, bytes = 0;
    corofem_scene *scene = NULL;
    corofem_settings settings;
    corofem_material material;
    float pull[3];

    CHECK(corofem_settings_default(&settings));
    settings.dt = 0.001f;
    /* The paper's CG with 10 iterations, cold: the same settings in every
       build (a microcontroller's leaves the two-level preconditioner out),
       and no first step that prepares a coarse factor. */
    settings.method = COROFEM_METHOD_QR;
    settings.preconditioner = COROFEM_PRECONDITIONER_MASS;
    settings.warm_start = 0;
    settings.cg_iterations = 10;
    if (is_box) {
        const float size[3] = {0.1f, 0.02f, 0.02f};
        const uint32_t cells[3] = {10, 2, 2};
        CHECK(corofem_box_mesh(size, cells, 6, nodes, 3 * MAX_NODES, tets, 4 * MAX_TETS, &n, &t));
        material = (corofem_material){.young = 1.0e5f, .poisson = 0.4f, .density = 1000.0f};
        settings.rayleigh_mass = 5.0f;
        pull[0] = 0.0f, pull[1] = 0.0f, pull[2] = -0.02f;
    } else {
#if HAVE_FILES
        if (read_tetmesh(mesh, 0.03, &n, &t) != 0) return 1;
#else
        printf("error: no files on this target\n");
        return 1;
#endif
        material = (corofem_material){.young = 5.0e3f, .poisson = 0.45f, .density = 1000.0f};
        settings.rayleigh_mass = 1.0f;
        settings.rayleigh_stiffness = 0.01f;
        settings.gravity[0] = 0.0f, settings.gravity[1] = -9.81f, settings.gravity[2] = 0.0f;
        pull[0] = 0.03f, pull[1] = 0.02f, pull[2] = 0.0f;
    }

    /* The ten lines of an embedding: size, init, build, configure. */
    CHECK(corofem_scene_bytes(n, t, &bytes));
    if (bytes > sizeof arena) {
        printf("error: scene needs %lu bytes, arena has %lu\n", (unsigned long)bytes,
               (unsigned long)sizeof arena);
        return 1;
    }
    CHECK(corofem_scene_init(arena, sizeof arena, n, t, &scene));
    CHECK(corofem_build(scene, nodes, n, tets, t, &material, 0, NULL));
    CHECK(corofem_set_settings(scene, &settings));

    if (is_box) {
        /* Node (i, j, k) has index i + 11 (j + 3 k): fix i = 0, grab i = 10. */
        uint32_t fixed[9], tip[9];
        for (uint32_t jk = 0; jk < 9; jk++) {
            fixed[jk] = 11 * jk;
            tip[jk] = 11 * jk + 10;
        }
        if (!with_probe) {
            CHECK(corofem_fix_nodes(scene, fixed, 9));
            CHECK(corofem_grab(scene, tip, 9, 500.0f));
        }
    } else if (!with_probe) {
        const uint32_t fixed[3] = {3, 39, 64};
        const uint32_t tip[5] = {80, 81, 78, 83, 82};
        CHECK(corofem_fix_nodes(scene, fixed, 3));
        CHECK(corofem_grab(scene, tip, 5, 2000.0f));
    }

    float start[3], force[3] = {0.0f, 0.0f, 0.0f};
    corofem_stats stats;
    CHECK(corofem_tool_target(scene, start));
    /* %lu, not %zu: newlib's printf does not know %zu. */
    printf("scene %s%s%s: %lu nodes, %lu tets, %lu bytes\n", is_box ? "box" : mesh,
           with_probe ? (with_friction ? " with a probe and friction" : " with a probe") : "",
           with_coupling ? ", coupled" : "", (unsigned long)n, (unsigned long)t,
           (unsigned long)bytes);

    /* The probe scene: one sphere in its own buffer, started above the
     * pressed node (the box's node 84, or the liver's topmost), moved along
     * probe_path each step. */
    corofem_probes *probes = NULL;
    int up = is_box ? 2 : 1; /* against gravity */
    float c0[3] = {0.0f, 0.0f, 0.0f}, b[3] = {0.0f, 0.0f, 0.0f}, peak_push = 0.0f;
    uint32_t pressed = 84, peak_step = 0, contacts = 0;
    /* The coupling (--coupling): a plain struct, no buffer; the device's
     * last position, and the largest rendered force's square. */
    corofem_coupling coupling;
    float device[3] = {0.0f, 0.0f, 0.0f}, render[3] = {0.0f, 0.0f, 0.0f}, peak_render2 = 0.0f;
    uint32_t peak_render_step = 0;
    if (with_probe) {
        size_t probe_bytes = 0;
        corofem_status st = corofem_probes_bytes(1, &probe_bytes);
        if (st == COROFEM_STATUS_UNSUPPORTED) {
            printf("probe: not in this library\n");
            return 0;
        }
        CHECK(st);
        if (probe_bytes > sizeof probe_buffer) {
            printf("error: a probe needs %lu bytes\n", (unsigned long)probe_bytes);
            return 1;
        }
        /* The tray: every node within `tray` of the lowest (on the box, the
         * bottom face), fixed. */
        const float tray = is_box ? 0.0f : 0.03f;
        float lowest = nodes[up];
        for (uint32_t i = 1; i < n; i++) {
            if (nodes[3 * i + up] < lowest) lowest = nodes[3 * i + up];
        }
        uint32_t n_tray = 0;
        for (uint32_t i = 0; i < n; i++) {
            if (nodes[3 * i + up] <= lowest + tray) on_tray[n_tray++] = i;
        }
        CHECK(corofem_fix_nodes(scene, on_tray, n_tray));
        printf("probe: %lu nodes on the tray\n", (unsigned long)n_tray);
        if (!is_box) { /* the first node of the largest height */
            pressed = 0;
            for (uint32_t i = 1; i < n; i++) {
                if (nodes[3 * i + up] > nodes[3 * pressed + up]) pressed = i;
            }
        }
        c0[0] = nodes[3 * pressed], c0[1] = nodes[3 * pressed + 1], c0[2] = nodes[3 * pressed + 2];
        /* Start 2 mm above the node; deepest with the sphere's bottom
         * PROBE_DEPTH below it. */
        b[0] = c0[0], b[1] = c0[1], b[2] = c0[2];
        c0[up] = c0[up] + (PROBE_RADIUS + 0.002f);
        b[up] = b[up] + (PROBE_RADIUS - PROBE_DEPTH);
        settings.gravity[0] = 0.0f, settings.gravity[1] = 0.0f, settings.gravity[2] = 0.0f;
        CHECK(corofem_set_settings(scene, &settings));
        CHECK(corofem_probes_init(probe_buffer, sizeof probe_buffer, 1, &probes));
        CHECK(corofem_probes_add_sphere(probes, PROBE_RADIUS, c0, NULL));
        if (with_friction) CHECK(corofem_probe_set_friction(probes, 0, 0.6f, 0.4f));
        printf("probe: sphere of %.3f m over node %lu, %lu bytes\n", (double)PROBE_RADIUS,
               (unsigned long)pressed, (unsigned long)probe_bytes);
    }
    if (with_coupling) {
        /* The README's guide for a device of damping 1 N s/m at 1 kHz: k
         * half of 2 B / T, a proxy period 2 pi sqrt(m / k) of 20 ms, and a
         * damping ratio b / (2 sqrt(k m)) of 0.32. */
        const float k = 1000.0f, damper = 2.0f, m = 0.01f;
        corofem_status st = corofem_coupling_init(&coupling, k, damper, m);
        if (st == COROFEM_STATUS_UNSUPPORTED) {
            printf("coupling: not in this library\n");
            return 0;
        }
        CHECK(st);
        device[0] = c0[0], device[1] = c0[1], device[2] = c0[2];
        printf("coupling: k %.0f N/m, b %.1f N s/m, proxy %.3f kg, %lu bytes\n", (double)k,
               (double)damper, (double)m, (unsigned long)sizeof coupling);
    }
    if (is_box && !with_probe) {
        int r = bind_skin(scene);
        if (r == 1) return 1;
        if (r == 2) printf("surface: not in this library\n");
    }

#if HAVE_CLOCK
    if (steps > sizeof step_ns / sizeof step_ns[0]) steps = sizeof step_ns / sizeof step_ns[0];
    /* The real-time set-up of capi/examples/rt_loop.rs, as far as it needs
     * no privileges: memory locked (reported if refused), the timings'
     * pages touched before the loop, and on Linux timers that fire at the
     * deadline instead of up to 50 us late; the loop sleeps until 50 us
     * before each deadline and spins the rest. */
    const int64_t spin = 50000;
    int locked = 0, slack = 0;
    memset(step_ns, 0xff, sizeof step_ns);
    if (rt) {
        locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
#if defined(__linux__)
        slack = prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0;
#endif
    }
    int64_t period = 1000000, deadline = now_ns() + period;
    uint32_t misses = 0;
#endif
    for (uint32_t i = 0; i < steps; i++) {
        float a = triangle(i + 1);
        float target[3] = {start[0] + a * pull[0], start[1] + a * pull[1], start[2] + a * pull[2]};
        float at[3];
        if (with_probe) probe_path(c0, b, i + 1, at);
#if HAVE_CLOCK
        if (rt) {
            int64_t wake = deadline - spin;
            struct timespec ts = {(time_t)(wake / 1000000000), (long)(wake % 1000000000)};
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
            while (now_ns() < deadline) {
            }
        }
        int64_t t0 = now_ns();
#endif
        if (with_coupling) {
            /* One period of a coupled device loop: the device's position
             * and velocity in, the proxy driven, a step, the coupling's
             * force to render out. */
            float velocity[3];
            for (int c = 0; c < 3; c++) velocity[c] = (at[c] - device[c]) / settings.dt;
            CHECK(corofem_coupling_drive(&coupling, probes, 0, at, velocity, settings.dt, render));
            CHECK(corofem_step_probes(scene, probes, &stats, NULL, NULL));
            CHECK(corofem_probe_force(probes, 0, force, &contacts));
            device[0] = at[0], device[1] = at[1], device[2] = at[2];
        } else if (with_probe) {
            /* One period of a device loop: the device's position in, a
             * step, the force to render out. */
            CHECK(corofem_probe_move_to(probes, 0, at, NULL));
            CHECK(corofem_step_probes(scene, probes, &stats, NULL, NULL));
            CHECK(corofem_probe_force(probes, 0, force, &contacts));
        } else {
            CHECK(corofem_step_haptic(scene, target, force, &stats));
        }
#if HAVE_CLOCK
        int64_t t1 = now_ns();
        step_ns[i] = t1 - t0;
        if (rt) {
            if (t1 > deadline + period) misses++;
            deadline += period;
            while (deadline < t1) deadline += period; /* skip missed periods */
        }
#endif
        if (with_probe && force[up] > peak_push) peak_push = force[up], peak_step = i + 1;
        if (with_coupling) {
            float r2 = render[0] * render[0] + render[1] * render[1] + render[2] * render[2];
            if (r2 > peak_render2) peak_render2 = r2, peak_render_step = i + 1;
        }

    }

    uint64_t hash = 0;
    CHECK(corofem_state_hash(scene, &hash));
    CHECK(corofem_positions(scene, positions, 3 * MAX_NODES));
    /* 64-bit values printed as 32-bit halves: newlib's <inttypes.h> lacks PRIx64. */
    printf("steps %lu, time %.3f s, cg residual %.3e, inverted %" PRIu32 "\n", (unsigned long)stats.steps,
           stats.time, (double)stats.cg_residual, stats.inverted);
    if (with_probe) {
        printf("probe force %.6f %.6f %.6f N, %" PRIu32 " contacts; largest push %.6f N at step %" PRIu32
               "\n",
               (double)force[0], (double)force[1], (double)force[2], contacts, (double)peak_push,
               peak_step);
        printf("support force %.6f %.6f %.6f N, %" PRIu32 " contacts in all\n",
               (double)stats.support_force[0], (double)stats.support_force[1],
               (double)stats.support_force[2], stats.contacts);
        if (with_coupling) {
            float body = 0.0f;
            CHECK(corofem_coupling_body_stiffness(&coupling, &body));
            printf("rendered force %.6f %.6f %.6f N; largest %.6f N at step %" PRIu32
                   "; body stiffness %.1f N/m\n",
                   (double)render[0], (double)render[1], (double)render[2], sqrt((double)peak_render2),
                   peak_render_step, (double)body);
        }
    } else {
        printf("tool force %.6f %.6f %.6f N\n", (double)force[0], (double)force[1], (double)force[2]);
    }
    printf("node 0 at %.6f %.6f %.6f m\n", (double)positions[0], (double)positions[1],
           (double)positions[2]);
#if HAVE_CLOCK
    if (steps > 0) {
        /* Nearest-rank percentiles, as rt_loop's. */
        qsort(step_ns, steps, sizeof step_ns[0], cmp_i64);
        printf("step time: p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us",
               pct(step_ns, steps, 500) / 1e3, pct(step_ns, steps, 990) / 1e3,
               pct(step_ns, steps, 999) / 1e3, step_ns[steps - 1] / 1e3);
        if (rt) {
            printf(", deadline misses %" PRIu32 " of %" PRIu32 " (mlockall %s, timer slack 1 ns %s)",
                   misses, steps, locked ? "yes" : "refused", slack ? "yes" : "no");
        }
        printf("\n");
    }
#endif
    if (skin) {
        /* Each frame a renderer would do this: the tube's tip ring, moved. */
        CHECK(corofem_update_surface(scene, skin, skin_out, 3 * SKIN_V, skin_normals, 3 * SKIN_V));
        float tip[3] = {0.0f, 0.0f, 0.0f};
        for (uint32_t k = 0; k < SKIN_RING; k++) {
            for (int c = 0; c < 3; c++) tip[c] += skin_out[3 * ((SKIN_RINGS - 1) * SKIN_RING + k) + c];
        }
        printf("surface tip ring centre %.6f %.6f %.6f m\n", (double)(tip[0] / SKIN_RING),
               (double)(tip[1] / SKIN_RING), (double)(tip[2] / SKIN_RING));
    }
    /* Error handling: every misuse is a status code. */
    if (corofem_step(NULL, NULL) != COROFEM_STATUS_NULL_POINTER ||
        corofem_fix_nodes(scene, (const uint32_t[]){100000}, 1) != COROFEM_STATUS_INDEX_OUT_OF_RANGE ||
        corofem_positions(scene, positions, 2) != COROFEM_STATUS_BUFFER_TOO_SMALL) {
        printf("error: misuse not reported\n");
        return 1;
    }
    CHECK(corofem_scene_deinit(scene));
    if (corofem_step(scene, NULL) != COROFEM_STATUS_INVALID_HANDLE) {
        printf("error: dead handle not reported\n");
        return 1;
    }
    /* Memory for a few scene sizes with this library's features. */
    static const size_t sizes[][2] = {{99, 240}, {181, 596}, {512, 2058}, {882, 2851}, {2197, 10368}};
    printf("scene bytes:");
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        CHECK(corofem_scene_bytes(sizes[k][0], sizes[k][1], &bytes));
        printf(" %lu/%lu: %lu;", (unsigned long)sizes[k][0], (unsigned long)sizes[k][1],
               (unsigned long)bytes);
    }
    printf("\n");
    printf("hash %08" PRIx32 "%08" PRIx32 "\n", (uint32_t)(hash >> 32), (uint32_t)hash);
    return 0;
}
