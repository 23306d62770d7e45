/*
 * embree_limit.c -- the "single-ray limit" benchmark.
 *
 * Traces an NFF scene (Eric Haines's Neutral File Format) with Embree's single-ray
 * kernels (rtcIntersect1 for eye rays, rtcOccluded1 for shadow rays) on one thread:
 * one eye ray per pixel and, for each eye hit, one shadow ray per light that is in
 * front of the surface. There is no shading, no reflection and no refraction. The
 * time it takes is what a single-ray, single-thread ray tracer can be compared
 * against.
 *
 * Build (Debian's libembree-dev, Embree 3.13):
 *   cc -O3 -march=native -std=c11 -Wall -Wextra -o /tmp/embree_limit \
 *       bench/limit/embree_limit.c -lembree3 -lm
 *
 * Run:
 *   embree_limit SCENE.nff [--resolution WxH] [--repeat N] [--quality low|medium|high]
 * Defaults: the NFF's own `resolution` line (else 512x512), 5 repeats, high quality.
 *
 * Prints exactly one JSON line on stdout:
 *   {"scene":"...","width":W,"height":H,"triangles":N,"spheres":N,
 *    "build_s":best,"trace_s":best,"eye":N,"eye_hits":N,"shadow":N,
 *    "shadow_blocked":N,"shadow_behind":N}
 * build_s: the best (minimum) over the repeats of rtcNewScene .. rtcCommitScene
 *          (geometry creation, buffer fill and commit; not the file parsing);
 * trace_s: the best over the repeats of the whole trace loop (eye + shadow rays);
 * counts:  those of one repeat (they are the same in each): eye rays, eye rays that
 *          hit, shadow rays shot, shadow rays blocked, and (light, hit) pairs skipped
 *          because the light is behind the surface.
 *
 * Supported NFF: v from at up angle hither resolution b l f p pp s and `#` comment
 * lines; `c` (cones/cylinders) and anything else is an error. Errors go to stderr as
 * one line `embree_limit: FILE:LINE: what`, exit status 2.
 *
 * Camera (identical to the renderer it is compared against): the full vertical angle
 * spans the centres of the top and bottom pixel rows; pixels are square; row 0 is at
 * the top; the ray through pixel (i, j) passes through its centre (i + 0.5, j + 0.5).
 */
#define _POSIX_C_SOURCE 200809L

#include <embree3/rtcore.h>

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ------------------------------------------------------------------------ errors */

static const char *g_file = "?";

static void die(int line, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "embree_limit: %s:%d: ", g_file, line);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    exit(2);
}

static void usage(const char *what)
{
    fprintf(stderr, "embree_limit: %s\n", what);
    fprintf(stderr, "usage: embree_limit SCENE.nff [--resolution WxH] [--repeat N] "
                    "[--quality low|medium|high]\n");
    exit(2);
}

static void embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    fprintf(stderr, "embree_limit: embree error %d: %s\n", (int)code, str ? str : "");
    exit(2);
}

static void *xrealloc(void *p, size_t n)
{
    void *q = realloc(p, n ? n : 1);
    if (!q) {
        fprintf(stderr, "embree_limit: out of memory\n");
        exit(2);
    }
    return q;
}

/* ----------------------------------------------------------------------- scanner */

typedef struct {
    const char *buf;
    size_t len, pos;
    int line;
} Scanner;

typedef struct {
    char text[128];
    int line; /* line of the token's start; the last line at end of file */
    int eof;
} Token;

/* Reads the next white-space separated token, skipping `#` comments to end of line. */
static Token next_token(Scanner *s)
{
    Token t;
    t.text[0] = '\0';
    t.eof = 0;
    for (;;) {
        while (s->pos < s->len) {
            char c = s->buf[s->pos];
            if (c == '\n')
                s->line++;
            else if (!(c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v' ||
                       c == '\0'))
                break;
            s->pos++;
        }
        if (s->pos < s->len && s->buf[s->pos] == '#') {
            while (s->pos < s->len && s->buf[s->pos] != '\n')
                s->pos++;
            continue;
        }
        break;
    }
    t.line = s->line;
    if (s->pos >= s->len) {
        t.eof = 1;
        if (s->len > 0 && s->buf[s->len - 1] == '\n' && t.line > 1)
            t.line--; /* the last line, not the empty one after the final newline */
        return t;
    }
    size_t start = s->pos, n;
    while (s->pos < s->len) {
        char c = s->buf[s->pos];
        if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v' || c == '\n' ||
            c == '\0')
            break;
        s->pos++;
    }
    n = s->pos - start;
    if (n >= sizeof t.text)
        die(t.line, "token too long: '%.20s...'", s->buf + start);
    memcpy(t.text, s->buf + start, n);
    t.text[n] = '\0';
    return t;
}

static int parse_number(const char *text, double *out)
{
    if (!strchr("+-.0123456789", text[0]) || text[0] == '\0')
        return 0;
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || !isfinite(v))
        return 0;
    *out = v;
    return 1;
}

static double need_number(Scanner *s, const char *what)
{
    Token t = next_token(s);
    double v;
    if (t.eof)
        die(t.line, "unexpected end of file, expected %s", what);
    if (!parse_number(t.text, &v))
        die(t.line, "bad token '%s', expected %s", t.text, what);
    return v;
}

static long need_count(Scanner *s, const char *what)
{
    Token t = next_token(s);
    if (t.eof)
        die(t.line, "unexpected end of file, expected %s", what);
    char *end;
    errno = 0;
    long v = strtol(t.text, &end, 10);
    if (end == t.text || *end != '\0' || errno || v < 0 || v > 100000000L)
        die(t.line, "bad token '%s', expected %s", t.text, what);
    return v;
}

/* Consumes the next token if it is a number. */
static int maybe_number(Scanner *s, double *out)
{
    Scanner save = *s;
    Token t = next_token(s);
    if (!t.eof && parse_number(t.text, out))
        return 1;
    *s = save;
    return 0;
}

/* ------------------------------------------------------------------------- scene */

typedef struct {
    double x, y, z;
} Vec3d;

typedef struct {
    Vec3d from, at, up;
    double angle;
    int width, height; /* 0 when the file has no resolution line */

    float *tri_vertices; /* x y z */
    size_t n_tri_vertices, cap_tri_vertices;
    unsigned *tri_indices; /* a b c */
    size_t n_triangles, cap_triangles;

    float *spheres; /* x y z r */
    size_t n_spheres, cap_spheres;

    float *lights; /* x y z */
    size_t n_lights, cap_lights;
} Scene;

static Vec3d need_vec3(Scanner *s, const char *what)
{
    Vec3d v;
    v.x = need_number(s, what);
    v.y = need_number(s, what);
    v.z = need_number(s, what);
    return v;
}

static unsigned add_vertex(Scene *sc, Vec3d v)
{
    if (sc->n_tri_vertices == sc->cap_tri_vertices) {
        sc->cap_tri_vertices = sc->cap_tri_vertices ? 2 * sc->cap_tri_vertices : 1024;
        sc->tri_vertices =
            xrealloc(sc->tri_vertices, sc->cap_tri_vertices * 3 * sizeof(float));
    }
    float *p = sc->tri_vertices + 3 * sc->n_tri_vertices;
    p[0] = (float)v.x;
    p[1] = (float)v.y;
    p[2] = (float)v.z;
    return (unsigned)sc->n_tri_vertices++;
}

static void add_triangle(Scene *sc, unsigned a, unsigned b, unsigned c)
{
    if (sc->n_triangles == sc->cap_triangles) {
        sc->cap_triangles = sc->cap_triangles ? 2 * sc->cap_triangles : 1024;
        sc->tri_indices = xrealloc(sc->tri_indices, sc->cap_triangles * 3 * sizeof(unsigned));
    }
    unsigned *p = sc->tri_indices + 3 * sc->n_triangles++;
    p[0] = a;
    p[1] = b;
    p[2] = c;
}

/* A polygon of n vertices (each followed by a normal when with_normals), as a fan. */
static void read_polygon(Scanner *s, Scene *sc, int with_normals, int line)
{
    long n = need_count(s, "a vertex count");
    if (n < 3)
        die(line, "polygon with %ld vertices (at least 3 needed)", n);
    unsigned first = 0;
    for (long i = 0; i < n; i++) {
        Vec3d v = need_vec3(s, "a vertex coordinate");
        if (with_normals)
            (void)need_vec3(s, "a normal coordinate");
        unsigned idx = add_vertex(sc, v);
        if (i == 0)
            first = idx;
        else if (i >= 2)
            add_triangle(sc, first, idx - 1, idx);
    }
}

static void parse_nff(const char *buf, size_t len, Scene *sc)
{
    Scanner s = {buf, len, 0, 1};
    memset(sc, 0, sizeof *sc);
    sc->up.z = 1.0;
    sc->at.z = -1.0;
    sc->angle = 45.0;
    for (;;) {
        Token t = next_token(&s);
        if (t.eof)
            break;
        const char *k = t.text;
        if (strcmp(k, "v") == 0) {
            /* the view block: its entries are handled as keywords of their own */
        } else if (strcmp(k, "from") == 0) {
            sc->from = need_vec3(&s, "a 'from' coordinate");
        } else if (strcmp(k, "at") == 0) {
            sc->at = need_vec3(&s, "an 'at' coordinate");
        } else if (strcmp(k, "up") == 0) {
            sc->up = need_vec3(&s, "an 'up' coordinate");
        } else if (strcmp(k, "angle") == 0) {
            sc->angle = need_number(&s, "an angle");
        } else if (strcmp(k, "hither") == 0) {
            (void)need_number(&s, "a hither distance");
        } else if (strcmp(k, "resolution") == 0) {
            long w = need_count(&s, "a width");
            long h = need_count(&s, "a height");
            if (w < 1 || h < 1 || w > 65536 || h > 65536)
                die(t.line, "bad resolution %ld %ld", w, h);
            sc->width = (int)w;
            sc->height = (int)h;
        } else if (strcmp(k, "b") == 0) {
            (void)need_vec3(&s, "a background colour");
        } else if (strcmp(k, "l") == 0) {
            Vec3d p = need_vec3(&s, "a light coordinate");
            double c;
            for (int i = 0; i < 3 && maybe_number(&s, &c); i++) {
            }
            if (sc->n_lights == sc->cap_lights) {
                sc->cap_lights = sc->cap_lights ? 2 * sc->cap_lights : 16;
                sc->lights = xrealloc(sc->lights, sc->cap_lights * 3 * sizeof(float));
            }
            float *q = sc->lights + 3 * sc->n_lights++;
            q[0] = (float)p.x;
            q[1] = (float)p.y;
            q[2] = (float)p.z;
        } else if (strcmp(k, "f") == 0) {
            for (int i = 0; i < 8; i++)
                (void)need_number(&s, "a material number");
        } else if (strcmp(k, "p") == 0) {
            read_polygon(&s, sc, 0, t.line);
        } else if (strcmp(k, "pp") == 0) {
            read_polygon(&s, sc, 1, t.line);
        } else if (strcmp(k, "s") == 0) {
            Vec3d c = need_vec3(&s, "a sphere centre coordinate");
            double r = need_number(&s, "a sphere radius");
            if (sc->n_spheres == sc->cap_spheres) {
                sc->cap_spheres = sc->cap_spheres ? 2 * sc->cap_spheres : 64;
                sc->spheres = xrealloc(sc->spheres, sc->cap_spheres * 4 * sizeof(float));
            }
            float *q = sc->spheres + 4 * sc->n_spheres++;
            q[0] = (float)c.x;
            q[1] = (float)c.y;
            q[2] = (float)c.z;
            q[3] = (float)fabs(r);
        } else if (strcmp(k, "c") == 0) {
            die(t.line, "cones are not supported");
        } else {
            die(t.line, "unsupported primitive or bad token '%s'", k);
        }
    }
}

static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        die(0, "cannot read: %s", strerror(errno));
    char *buf = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (cap - n < 65536) {
            cap = cap ? 2 * cap : 1 << 20;
            buf = xrealloc(buf, cap);
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            if (ferror(f))
                die(0, "cannot read: %s", strerror(errno));
            break;
        }
    }
    fclose(f);
    *len = n;
    return buf;
}

/* ------------------------------------------------------------------------ embree */

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static RTCScene build_scene(RTCDevice dev, const Scene *sc, enum RTCBuildQuality q)
{
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_NONE);
    rtcSetSceneBuildQuality(scene, q);
    if (sc->n_triangles > 0) {
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, q);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                           3 * sizeof(float), sc->n_tri_vertices);
        memcpy(v, sc->tri_vertices, sc->n_tri_vertices * 3 * sizeof(float));
        unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                               3 * sizeof(unsigned), sc->n_triangles);
        memcpy(ix, sc->tri_indices, sc->n_triangles * 3 * sizeof(unsigned));
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    if (sc->n_spheres > 0) {
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        rtcSetGeometryBuildQuality(g, q);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                           4 * sizeof(float), sc->n_spheres);
        memcpy(v, sc->spheres, sc->n_spheres * 4 * sizeof(float));
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(scene);
    return scene;
}

typedef struct {
    unsigned long long eye, eye_hits, shadow, shadow_blocked, shadow_behind;
} Counts;

static Vec3d v_sub(Vec3d a, Vec3d b) { return (Vec3d){a.x - b.x, a.y - b.y, a.z - b.z}; }
static Vec3d v_cross(Vec3d a, Vec3d b)
{
    return (Vec3d){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static Vec3d v_norm(Vec3d a)
{
    double l = sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
    return (Vec3d){a.x / l, a.y / l, a.z / l};
}

static Counts trace(RTCScene scene, const Scene *sc, int w, int h)
{
    Counts c = {0, 0, 0, 0, 0};
    const double pi = 3.14159265358979323846;
    Vec3d fwd = v_norm(v_sub(sc->at, sc->from));
    Vec3d right = v_norm(v_cross(fwd, sc->up));
    Vec3d up2 = v_cross(right, fwd);
    double half = sc->angle * 0.5 * pi / 180.0;
    double pixel = 2.0 * tan(half) / (double)(h > 1 ? h - 1 : 1);
    const float ox = (float)sc->from.x, oy = (float)sc->from.y, oz = (float)sc->from.z;

    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);

    for (int j = 0; j < h; j++) {
        double y = ((double)h * 0.5 - ((double)j + 0.5)) * pixel;
        for (int i = 0; i < w; i++) {
            double x = (((double)i + 0.5) - (double)w * 0.5) * pixel;
            Vec3d d = {fwd.x + right.x * x + up2.x * y, fwd.y + right.y * x + up2.y * y,
                       fwd.z + right.z * x + up2.z * y};
            d = v_norm(d);

            struct RTCRayHit rh;
            rh.ray.org_x = ox;
            rh.ray.org_y = oy;
            rh.ray.org_z = oz;
            rh.ray.tnear = 0.0f;
            rh.ray.dir_x = (float)d.x;
            rh.ray.dir_y = (float)d.y;
            rh.ray.dir_z = (float)d.z;
            rh.ray.time = 0.0f;
            rh.ray.tfar = INFINITY;
            rh.ray.mask = (unsigned)-1;
            rh.ray.id = 0;
            rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            c.eye++;
            rtcIntersect1(scene, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
                continue;
            c.eye_hits++;

            float t = rh.ray.tfar;
            float dx = rh.ray.dir_x, dy = rh.ray.dir_y, dz = rh.ray.dir_z;
            float px = ox + t * dx, py = oy + t * dy, pz = oz + t * dz;
            float nx = rh.hit.Ng_x, ny = rh.hit.Ng_y, nz = rh.hit.Ng_z;
            float nl = sqrtf(nx * nx + ny * ny + nz * nz);
            if (nl > 0.0f) {
                nx /= nl;
                ny /= nl;
                nz /= nl;
            }
            if (nx * dx + ny * dy + nz * dz > 0.0f) {
                nx = -nx;
                ny = -ny;
                nz = -nz;
            }
            float m = fmaxf(fabsf(px), fmaxf(fabsf(py), fabsf(pz)));
            float eps = 1e-4f * fmaxf(1.0f, m);
            float sx = px + nx * eps, sy = py + ny * eps, sz = pz + nz * eps;

            for (size_t k = 0; k < sc->n_lights; k++) {
                const float *L = sc->lights + 3 * k;
                float tx = L[0] - px, ty = L[1] - py, tz = L[2] - pz;
                float dist = sqrtf(tx * tx + ty * ty + tz * tz);
                float lx = tx / dist, ly = ty / dist, lz = tz / dist;
                if (nx * lx + ny * ly + nz * lz <= 0.0f) {
                    c.shadow_behind++;
                    continue;
                }
                struct RTCRay r;
                r.org_x = sx;
                r.org_y = sy;
                r.org_z = sz;
                r.tnear = 0.0f;
                r.dir_x = lx;
                r.dir_y = ly;
                r.dir_z = lz;
                r.time = 0.0f;
                r.tfar = dist * (1.0f - 1e-4f);
                r.mask = (unsigned)-1;
                r.id = 0;
                r.flags = 0;
                c.shadow++;
                rtcOccluded1(scene, &ctx, &r);
                if (r.tfar == -INFINITY)
                    c.shadow_blocked++;
            }
        }
    }
    return c;
}

/* -------------------------------------------------------------------------- main */

static void print_json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\')
            printf("\\%c", ch);
        else if (ch < 0x20)
            printf("\\u%04x", ch);
        else
            putchar(ch);
    }
    putchar('"');
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    int width = 0, height = 0, repeat = 5;
    enum RTCBuildQuality quality = RTC_BUILD_QUALITY_HIGH;

    for (int a = 1; a < argc; a++) {
        if (strcmp(argv[a], "--resolution") == 0 && a + 1 < argc) {
            char *end;
            long w = strtol(argv[++a], &end, 10);
            long h = 0;
            if (*end == 'x' || *end == 'X')
                h = strtol(end + 1, &end, 10);
            if (*end != '\0' || w < 1 || h < 1 || w > 65536 || h > 65536)
                usage("bad --resolution (expected WxH)");
            width = (int)w;
            height = (int)h;
        } else if (strcmp(argv[a], "--repeat") == 0 && a + 1 < argc) {
            char *end;
            long n = strtol(argv[++a], &end, 10);
            if (*end != '\0' || n < 1 || n > 1000000)
                usage("bad --repeat (expected a positive integer)");
            repeat = (int)n;
        } else if (strcmp(argv[a], "--quality") == 0 && a + 1 < argc) {
            const char *q = argv[++a];
            if (strcmp(q, "low") == 0)
                quality = RTC_BUILD_QUALITY_LOW;
            else if (strcmp(q, "medium") == 0)
                quality = RTC_BUILD_QUALITY_MEDIUM;
            else if (strcmp(q, "high") == 0)
                quality = RTC_BUILD_QUALITY_HIGH;
            else
                usage("bad --quality (expected low, medium or high)");
        } else if (argv[a][0] == '-' && argv[a][1] != '\0') {
            usage("unknown option or missing value");
        } else if (!path) {
            path = argv[a];
        } else {
            usage("more than one scene file");
        }
    }
    if (!path)
        usage("no scene file");
    g_file = path;

    size_t len;
    char *buf = read_file(path, &len);
    Scene sc;
    parse_nff(buf, len, &sc);
    free(buf);
    if (width == 0) {
        width = sc.width ? sc.width : 512;
        height = sc.height ? sc.height : 512;
    }

    RTCDevice dev = rtcNewDevice("threads=1");
    if (!dev) {
        fprintf(stderr, "embree_limit: cannot create the Embree device (error %d)\n",
                (int)rtcGetDeviceError(NULL));
        return 2;
    }
    rtcSetDeviceErrorFunction(dev, embree_error, NULL);

    double best_build = INFINITY, best_trace = INFINITY;
    Counts counts = {0, 0, 0, 0, 0};
    for (int r = 0; r < repeat; r++) {
        double t0 = now_s();
        RTCScene scene = build_scene(dev, &sc, quality);
        double t1 = now_s();
        counts = trace(scene, &sc, width, height);
        double t2 = now_s();
        rtcReleaseScene(scene);
        if (t1 - t0 < best_build)
            best_build = t1 - t0;
        if (t2 - t1 < best_trace)
            best_trace = t2 - t1;
    }
    rtcReleaseDevice(dev);

    printf("{\"scene\":");
    print_json_string(path);
    printf(",\"width\":%d,\"height\":%d,\"triangles\":%zu,\"spheres\":%zu,"
           "\"build_s\":%.6f,\"trace_s\":%.6f,\"eye\":%llu,\"eye_hits\":%llu,"
           "\"shadow\":%llu,\"shadow_blocked\":%llu,\"shadow_behind\":%llu}\n",
           width, height, sc.n_triangles, sc.n_spheres, best_build, best_trace, counts.eye,
           counts.eye_hits, counts.shadow, counts.shadow_blocked, counts.shadow_behind);

    free(sc.tri_vertices);
    free(sc.tri_indices);
    free(sc.spheres);
    free(sc.lights);
    return 0;
}
