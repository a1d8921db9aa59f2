/* RTKLIB's own solution reader, for bench/ingest_formats.py: prints each solution of a .pos file as
 * "UTC-seconds lat-deg lon-deg height-m Q" (readsolt, then gpst2utc and ecef2pos).
 * Build against the RTKLIB sources (github.com/tomojitakasu/RTKLIB, src/):
 *   gcc -O1 -w -Isrc -DENAGLO -DENAGAL -DENAQZS -DENACMP -o readpos rtklib_readpos.c \
 *       $(ls src/*.c | grep -v -E "postpos|convrnx") src/rcv/*.c -lm -lpthread
 * and give its path in $RTKLIB_READPOS. */
#include "rtklib.h"
int main(int argc, char **argv) {
    solbuf_t sol = {0};
    char *files[] = {argv[1]};
    gtime_t t0 = {0};
    int i;
    if (!readsolt(files, 1, t0, t0, 0.0, 0, &sol)) { fprintf(stderr, "no solution\n"); return 1; }
    for (i = 0; i < sol.n; i++) {
        sol_t *s = sol.data + i;
        double pos[3];
        gtime_t u = gpst2utc(s->time);
        ecef2pos(s->rr, pos);
        printf("%.6f %.11f %.11f %.5f %d\n", (double)u.time + u.sec, pos[0] * R2D, pos[1] * R2D, pos[2], s->stat);
    }
    return 0;
}
int showmsg(char *format, ...) { return 0; }
void settspan(gtime_t ts, gtime_t te) {}
void settime(gtime_t time) {}
