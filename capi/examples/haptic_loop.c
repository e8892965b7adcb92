/* A haptic loop through the corofem C API.
 *
 *   haptic_loop [MESH.tetmesh|box] [STEPS] [--rt]
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
 * Scenes (both must match capi/tests/haptic_loop.rs exactly):
 *   box   (default) a 10 cm × 2 cm × 2 cm beam, 99 nodes / 240 tets,
 *         fixed at x = 0, grabbed at x = 10 cm, pulled down and back.
 *   MESH  SOFA's liver (sofa_liver.tetmesh) scaled by 0.03 to metres,
 *         fixed at nodes 3, 39, 64, grabbed at its tip, pulled out and back.
 *
 * --rt paces the loop at 1 kHz with absolute deadlines (POSIX hosts) and
 * reports deadline misses; without it the loop runs flat out.
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
#include <time.h>
#endif

/* Static storage: the mesh arrays and the scene arena. */
static float nodes[MAX_NODES * 3];
static uint32_t tets[MAX_TETS * 4];
static float positions[MAX_NODES * 3];
/* Large enough for MAX_NODES / MAX_TETS with every feature (checked below):
 * per node 96 B of state and scratch, 32 B of grab and load slots and 32 B
 * of preconditioner node block; per tetrahedron at most 136 B; and the
 * two-level preconditioner's aggregates: on the host at most 64 of 176 B
 * for 4 096 nodes, and the 385 rows of 48 slots of 32 B of their coarse
 * solve; none on bare metal, whose library is built without the
 * preconditioner (corofem_scene_bytes gives the exact need). */
#if defined(COROFEM_BARE_METAL)
#define AGGREGATE_BYTES 0
#else
#define AGGREGATE_BYTES (64 * 176 + 385 * 48 * 32)
#endif
static unsigned char arena[MAX_NODES * 160 + MAX_TETS * 136 + AGGREGATE_BYTES + 512];

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
#endif

/* The tool path: a triangle wave 0 → 1 → 0 over each second (1000 steps). */
static float triangle(uint32_t step) {
    float a = (float)(step % 1000u) / 1000.0f;
    return a < 0.5f ? 2.0f * a : 2.0f - 2.0f * a;
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
    "usage: haptic_loop [MESH.tetmesh|box] [STEPS] [--rt]\n"
    "\n"
    "Runs the haptic loop of the corofem C API example for STEPS steps of 1 ms\n"
    "(default 2000) on the built-in 10 x 2 x 2 cm beam (box, the default) or on\n"
    "a tetmesh file (SOFA's liver, scaled by 0.03 to metres), and prints the\n"
    "final tool force and a hash of the state.\n"
    "  --rt        pace the loop at 1 kHz and report deadline misses\n"
    "  -h, --help  print this help\n";

int main(int argc, char **argv) {
    /* Options first: anything else that starts with '-' is not a mesh file. */
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fputs(USAGE, stdout);
            return 0;
        }
        if (argv[i][0] == '-' && !(i == 3 && strcmp(argv[i], "--rt") == 0)) {
            printf("error: unknown option %s\n%s", argv[i], USAGE);
            return 2;
        }
    }
    const char *mesh = argc > 1 ? argv[1] : "box";
    uint32_t steps = argc > 2 ? (uint32_t)strtoul(argv[2], NULL, 10) : 2000;
    int rt = argc > 3 && strcmp(argv[3], "--rt") == 0;
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
        CHECK(corofem_fix_nodes(scene, fixed, 9));
        CHECK(corofem_grab(scene, tip, 9, 500.0f));
    } else {
        const uint32_t fixed[3] = {3, 39, 64};
        const uint32_t tip[5] = {80, 81, 78, 83, 82};
        CHECK(corofem_fix_nodes(scene, fixed, 3));
        CHECK(corofem_grab(scene, tip, 5, 2000.0f));
    }

    float start[3], force[3] = {0.0f, 0.0f, 0.0f};
    corofem_stats stats;
    CHECK(corofem_tool_target(scene, start));
    /* %lu, not %zu: newlib's printf does not know %zu. */
    printf("scene %s: %lu nodes, %lu tets, %lu bytes\n", is_box ? "box" : mesh, (unsigned long)n,
           (unsigned long)t, (unsigned long)bytes);
    if (is_box) {
        int r = bind_skin(scene);
        if (r == 1) return 1;
        if (r == 2) printf("surface: not in this library\n");
    }

#if HAVE_CLOCK
    if (steps > sizeof step_ns / sizeof step_ns[0]) steps = sizeof step_ns / sizeof step_ns[0];
    int64_t period = 1000000, deadline = now_ns() + period;
    uint32_t misses = 0;
#endif
    for (uint32_t i = 0; i < steps; i++) {
        float a = triangle(i + 1);
        float target[3] = {start[0] + a * pull[0], start[1] + a * pull[1], start[2] + a * pull[2]};
#if HAVE_CLOCK
        if (rt) {
            struct timespec ts = {(time_t)(deadline / 1000000000), (long)(deadline % 1000000000)};
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
        }
        int64_t t0 = now_ns();
#endif
        CHECK(corofem_step_haptic(scene, target, force, &stats));
#if HAVE_CLOCK
        int64_t t1 = now_ns();
        step_ns[i] = t1 - t0;
        if (rt) {
            if (t1 > deadline + period) misses++;
            deadline += period;
            while (deadline < t1) deadline += period; /* skip missed periods */
        }
#endif
    }

    uint64_t hash = 0;
    CHECK(corofem_state_hash(scene, &hash));
    CHECK(corofem_positions(scene, positions, 3 * MAX_NODES));
    /* 64-bit values printed as 32-bit halves: newlib's <inttypes.h> lacks PRIx64. */
    printf("steps %lu, time %.3f s, cg residual %.3e, inverted %" PRIu32 "\n", (unsigned long)stats.steps,
           stats.time, (double)stats.cg_residual, stats.inverted);
    printf("tool force %.6f %.6f %.6f N\n", (double)force[0], (double)force[1], (double)force[2]);
    printf("node 0 at %.6f %.6f %.6f m\n", (double)positions[0], (double)positions[1],
           (double)positions[2]);
#if HAVE_CLOCK
    if (steps > 0) {
        qsort(step_ns, steps, sizeof step_ns[0], cmp_i64);
        printf("step time: median %.1f us, p99 %.1f us, max %.1f us", step_ns[steps / 2] / 1e3,
               step_ns[(size_t)steps * 99 / 100] / 1e3, step_ns[steps - 1] / 1e3);
        if (rt) printf(", deadline misses %" PRIu32 " of %" PRIu32, misses, steps);
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
