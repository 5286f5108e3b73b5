/*
 * A game loop over the C core: a window (GLFW, OpenGL 1.x lines and points) shows a skeleton
 * playing a BVH clip through a layered mlr_stream with the guards (character.h), on a floor
 * grid. The simulation steps at a fixed 60 Hz (accumulator pattern); the window renders as
 * fast as vsync allows. The camera follows the character.
 *
 *     game_loop [CLIP.bvh] [--lag L] [--alpha A] [--no-filter] [--no-guards] [--size WxH]
 *               [--frames N --screenshot OUT.ppm] [--press FRAME:KEY]...
 *
 * Keys: Up/Down alpha +-0.25, 0/1/2/3 alpha 0 (the base layer), 1, 2, 3; F the filter on/off
 * (off: the raw clip, as far behind as the stream); G the guards on/off; Space pause; Esc quit.
 * --frames N: headless test mode: exactly one simulation step per rendered frame (the image
 * does not depend on the machine's speed), stop after N frames and write the framebuffer to
 * --screenshot as a binary PPM. --press FRAME:KEY presses KEY (Up, Down, 0-3, F, G) before
 * frame FRAME, as a player would.
 *
 * Build: cc game_loop.c character.c $(pkg-config --cflags --libs mlayer glfw3 gl) -lm
 */
#define _POSIX_C_SOURCE 200809L
#include "character.h"

#include <GLFW/glfw3.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef MLR_SAMPLE_CLIP
#define MLR_SAMPLE_CLIP "bindings/python/mlayer/data/cmu_131_01_mj_style_walk.bvh"
#endif

#define MAX_PRESS 32

typedef struct game {
    character ch;
    int paused;
    double cam[3]; /* the point the camera looks at (follows the root along the ground) */
} game;

static void say_state(const game *g)
{
    printf("alpha %.2f, filter %s, guards %s\n", g->ch.alpha, g->ch.filter ? "on" : "off",
           g->ch.guards ? "on" : "off");
    fflush(stdout);
}

static void press(game *g, int key)
{
    mlr_diag diag = {0};
    double a = g->ch.alpha;
    switch (key) {
    case GLFW_KEY_UP:
        a = a + 0.25 > 4.0 ? 4.0 : a + 0.25;
        break;
    case GLFW_KEY_DOWN:
        a = a - 0.25 < 0.0 ? 0.0 : a - 0.25;
        break;
    case GLFW_KEY_0:
    case GLFW_KEY_1:
    case GLFW_KEY_2:
    case GLFW_KEY_3:
        a = (double)(key - GLFW_KEY_0);
        break;
    case GLFW_KEY_F:
        char_set_filter(&g->ch, !g->ch.filter);
        break;
    case GLFW_KEY_G:
        if (char_set_guards(&g->ch, !g->ch.guards, &diag) < 0)
            fprintf(stderr, "game_loop: %s\n", diag.message);
        break;
    case GLFW_KEY_SPACE:
        g->paused = !g->paused;
        return;
    default:
        return;
    }
    if (a != g->ch.alpha && char_set_alpha(&g->ch, a, &diag) < 0)
        fprintf(stderr, "game_loop: %s\n", diag.message);
    say_state(g);
}

static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
    (void)scancode, (void)mods;
    if (action != GLFW_PRESS && action != GLFW_REPEAT)
        return;
    if (key == GLFW_KEY_ESCAPE)
        glfwSetWindowShouldClose(w, 1);
    else
        press(glfwGetWindowUserPointer(w), key);
}

static int key_by_name(const char *s)
{
    if (!strcmp(s, "Up"))
        return GLFW_KEY_UP;
    if (!strcmp(s, "Down"))
        return GLFW_KEY_DOWN;
    if (strlen(s) == 1 && s[0] >= '0' && s[0] <= '3')
        return GLFW_KEY_0 + (s[0] - '0');
    if (!strcmp(s, "F") || !strcmp(s, "f"))
        return GLFW_KEY_F;
    if (!strcmp(s, "G") || !strcmp(s, "g"))
        return GLFW_KEY_G;
    return -1;
}

/* A right-handed camera: eye looking at centre, `up` the clip's up axis. */
static void look_at(const double eye[3], const double centre[3], int up)
{
    double f[3], u[3] = {0, 0, 0}, s[3], t[3];
    u[up] = 1.0;
    double n = 0.0;
    for (int k = 0; k < 3; k++)
        f[k] = centre[k] - eye[k], n += f[k] * f[k];
    for (int k = 0; k < 3; k++)
        f[k] /= sqrt(n);
    s[0] = f[1] * u[2] - f[2] * u[1], s[1] = f[2] * u[0] - f[0] * u[2];
    s[2] = f[0] * u[1] - f[1] * u[0];
    n = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    for (int k = 0; k < 3; k++)
        s[k] /= n;
    t[0] = s[1] * f[2] - s[2] * f[1], t[1] = s[2] * f[0] - s[0] * f[2];
    t[2] = s[0] * f[1] - s[1] * f[0];
    const double m[16] = {s[0], t[0], -f[0], 0, s[1], t[1], -f[1], 0,
                          s[2], t[2], -f[2], 0, 0,    0,    0,     1};
    glMultMatrixd(m);
    glTranslated(-eye[0], -eye[1], -eye[2]);
}

static void vertex(const double *p) { glVertex3d(p[0], p[1], p[2]); }

static void draw(const game *g, int width, int height)
{
    const char_clip *cl = g->ch.clip;
    const int up = cl->up, a = (up + 1) % 3, b = (up + 2) % 3;
    const double h = cl->body_height > 0.0 ? cl->body_height : 1.0;
    const double floor_h = isnan(cl->floor_height) ? 0.0 : cl->floor_height;
    glViewport(0, 0, width, height);
    glClearColor(20 / 255.0f, 24 / 255.0f, 32 / 255.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glMatrixMode(GL_PROJECTION);
    glLoadIdentity();
    const double near = 0.05 * h, aspect = (double)width / (height > 0 ? height : 1);
    glFrustum(-near * 0.5 * aspect, near * 0.5 * aspect, -near * 0.5, near * 0.5, near, 40 * h);
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();
    double eye[3], centre[3];
    for (int k = 0; k < 3; k++)
        centre[k] = g->cam[k];
    centre[up] = floor_h + 0.5 * h;
    eye[a] = centre[a] + 1.6 * h, eye[b] = centre[b] + 1.4 * h, eye[up] = floor_h + 0.9 * h;
    look_at(eye, centre, up);

    /* The floor: a grid of half body heights, scrolling under the character. */
    const double step = 0.5 * h;
    const double ca = floor(g->cam[a] / step) * step, cb = floor(g->cam[b] / step) * step;
    glColor3ub(90, 90, 90);
    glLineWidth(1.0f);
    glBegin(GL_LINES);
    for (int i = -12; i <= 12; i++) {
        double p[3], q[3];
        p[up] = q[up] = floor_h;
        p[a] = q[a] = ca + i * step, p[b] = cb - 12 * step, q[b] = cb + 12 * step;
        vertex(p), vertex(q);
        p[b] = q[b] = cb + i * step, p[a] = ca - 12 * step, q[a] = ca + 12 * step;
        vertex(p), vertex(q);
    }
    glEnd();

    /* The skeleton: bones (orange), End Sites' bones, joints (white). */
    const int32_t *parents = cl->rig.parents;
    const double *wp = g->ch.world_pos;
    glColor3ub(255, 140, 0);
    glLineWidth(4.0f);
    glBegin(GL_LINES);
    for (size_t j = 1; j < cl->n_joints; j++)
        vertex(wp + 3 * j), vertex(wp + 3 * (size_t)parents[j]);
    for (size_t e = 0; e < cl->rig.n_end_sites; e++)
        vertex(g->ch.ends + 3 * e), vertex(wp + 3 * (size_t)cl->rig.end_site_parents[e]);
    glEnd();
    glDisable(GL_DEPTH_TEST);
    glColor3ub(255, 255, 255);
    glPointSize(6.0f);
    glBegin(GL_POINTS);
    for (size_t j = 0; j < cl->n_joints; j++)
        vertex(wp + 3 * j);
    glEnd();
}

/* The framebuffer as a binary PPM (rows from the top). */
static int screenshot(const char *path, int width, int height)
{
    const size_t row = 3 * (size_t)width;
    unsigned char *px = malloc(row * (size_t)height);
    if (!px)
        return -1;
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, px);
    FILE *f = fopen(path, "wb");
    int rc = f ? 0 : -1;
    if (f) {
        fprintf(f, "P6\n%d %d\n255\n", width, height);
        for (int y = height - 1; y >= 0 && rc == 0; y--)
            if (fwrite(px + (size_t)y * row, 1, row, f) != row)
                rc = -1;
        if (fclose(f) != 0)
            rc = -1;
    }
    free(px);
    return rc;
}

static void follow(game *g, double weight)
{
    const int up = g->ch.clip->up;
    for (int k = 0; k < 3; k++)
        if (k != up)
            g->cam[k] += weight * (g->ch.pose[k] - g->cam[k]);
}

int main(int argc, char **argv)
{
    const char *path = MLR_SAMPLE_CLIP, *shot = NULL;
    size_t lag = 10, frames = 0, n_press = 0;
    double alpha = 1.0;
    int filter = 1, guards = 1, width = 960, height = 640;
    size_t press_at[MAX_PRESS];
    int press_key[MAX_PRESS];
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(o, "--lag") && v)
            lag = strtoul(v, NULL, 10), i++;
        else if (!strcmp(o, "--alpha") && v)
            alpha = strtod(v, NULL), i++;
        else if (!strcmp(o, "--frames") && v)
            frames = strtoul(v, NULL, 10), i++;
        else if (!strcmp(o, "--screenshot") && v)
            shot = v, i++;
        else if (!strcmp(o, "--size") && v && sscanf(v, "%dx%d", &width, &height) == 2)
            i++;
        else if (!strcmp(o, "--press") && v && n_press < MAX_PRESS && strchr(v, ':') &&
                 key_by_name(strchr(v, ':') + 1) >= 0) {
            press_at[n_press] = strtoul(v, NULL, 10);
            press_key[n_press++] = key_by_name(strchr(v, ':') + 1);
            i++;
        } else if (!strcmp(o, "--no-filter"))
            filter = 0;
        else if (!strcmp(o, "--no-guards"))
            guards = 0;
        else if (o[0] != '-')
            path = o;
        else {
            fprintf(stderr,
                    "usage: %s [CLIP.bvh] [--lag L] [--alpha A] [--no-filter] [--no-guards] "
                    "[--size WxH] [--frames N --screenshot OUT.ppm] [--press FRAME:KEY]...\n",
                    argv[0]);
            return 2;
        }
    }
    if (shot && !frames) {
        fprintf(stderr, "game_loop: --screenshot needs --frames N\n");
        return 2;
    }
    if (width < 16 || height < 16) {
        fprintf(stderr, "game_loop: --size too small\n");
        return 2;
    }

    /* Load time: the clip, its guards' data and the character (everything allocated here). */
    mlr_diag diag = {0};
    char_clip clip;
    game g;
    memset(&g, 0, sizeof g);
    mlr_status s = char_clip_load(path, NULL, &clip, &diag);
    if (s < 0) {
        fprintf(stderr, "game_loop: %s: %s\n", path, diag.message);
        return 1;
    }
    s = char_init(&g.ch, &clip, 0, lag, NULL, &diag);
    if (s >= 0)
        s = char_set_alpha(&g.ch, alpha, &diag);
    if (s >= 0 && !guards)
        s = char_set_guards(&g.ch, 0, &diag);
    if (s >= 0)
        s = char_step(&g.ch, &diag); /* a first pose for the camera */
    if (s < 0) {
        fprintf(stderr, "game_loop: %s\n", diag.message);
        char_clip_free(&clip);
        return 1;
    }
    char_set_filter(&g.ch, filter);
    follow(&g, 1.0);
    printf("game_loop: %s, %zu joints, %zu frames at 60 Hz, %zu feet, floor %.3g, lag %zu\n", path,
           clip.n_joints, clip.n_frames, clip.n_feet, clip.floor_height, lag);
    say_state(&g);

    if (!glfwInit()) {
        fprintf(stderr, "game_loop: no display (glfwInit failed)\n");
        char_free(&g.ch);
        char_clip_free(&clip);
        return 1;
    }
    GLFWwindow *win = glfwCreateWindow(width, height, "mlayer game loop", NULL, NULL);
    int rc = 1;
    if (!win) {
        fprintf(stderr, "game_loop: no OpenGL window\n");
        goto done;
    }
    glfwMakeContextCurrent(win);
    glfwSwapInterval(frames ? 0 : 1);
    glfwSetWindowUserPointer(win, &g);
    glfwSetKeyCallback(win, on_key);

    const double dt = 1.0 / CHAR_STEP_HZ;
    double acc = 0.0, last = glfwGetTime();
    size_t rendered = 0;
    rc = 0;
    while (!glfwWindowShouldClose(win)) {
        for (size_t k = 0; k < n_press; k++)
            if (press_at[k] == rendered)
                press(&g, press_key[k]);
        const double t = glfwGetTime();
        /* Fixed step: as many 1/60 s steps as the elapsed time holds (at most 8: a stalled
         * window does not spiral); in test mode exactly one per frame. */
        acc += frames ? dt : (t - last > 8 * dt ? 8 * dt : t - last);
        last = t;
        while (acc >= dt - 1e-12) {
            acc -= dt;
            if (g.paused)
                continue;
            s = char_step(&g.ch, &diag);
            if (s < 0) {
                fprintf(stderr, "game_loop: step: %s\n", diag.message);
                rc = 1;
                glfwSetWindowShouldClose(win, 1);
                break;
            }
            follow(&g, 0.1);
        }
        int fw, fh;
        glfwGetFramebufferSize(win, &fw, &fh);
        draw(&g, fw, fh);
        rendered++;
        if (frames && rendered == frames) {
            if (shot && screenshot(shot, fw, fh) != 0) {
                fprintf(stderr, "game_loop: cannot write %s\n", shot);
                rc = 1;
            } else if (shot)
                printf("game_loop: frame %zu (clip frame %zu) -> %s\n", rendered,
                       char_shown_frame(&g.ch), shot);
            break;
        }
        glfwSwapBuffers(win);
        glfwPollEvents();
    }
done:
    if (win)
        glfwDestroyWindow(win);
    glfwTerminate();
    char_free(&g.ch);
    char_clip_free(&clip);
    return rc;
}
