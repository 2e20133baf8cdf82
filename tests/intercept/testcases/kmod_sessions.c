/* Sessions under contego.ko (issue 40 item 2, kernel half; the test bed's
 * scenario 63-kmod-sessions). N processes, each its own bound session, write
 * the PCA9685 at 0x40 through /dev/i2c-0 as periodic tasks: 3 SMBus
 * byte-data writes (LEDn_OFF_H, what `i2cset` sends) per 10 ms job, each
 * timed with CLOCK_MONOTONIC; then every process writes back to back for 1 s.
 * The same N processes and writes run first on the same adapter under the
 * plain i2c-dev (no contego.ko), then under contego.ko: i2c-dev and
 * contego.ko cannot be loaded together (both are major 89), so the caller
 * hands over two commands that switch the adapter between them.
 *
 *   kmod_sessions sweep COUNTS JOBS PLAIN_CMD KMOD_CMD
 *       COUNTS e.g. 1,16: for each N, PLAIN_CMD (system(3): i2c-dev in
 *       place), N processes on the plain adapter, KMOD_CMD (contego.ko in
 *       place, policy loaded, reader attached), the same N processes
 *       checked; one table row per N. Exit 1 when a periodic write failed
 *       or a session was not reclaimed (back to back, checked writes may
 *       fail closed, EIO, when the audit reader falls behind: counted in
 *       the row, not a failure).
 *   kmod_sessions cap N
 *       under contego.ko: N processes write once each and stay alive until
 *       every one has written; prints how many wrote, how many were refused
 *       EAGAIN (no room for a session: max_sessions), what the module counts,
 *       then lets them exit and times until the module has no session left.
 *
 * Process i is task t(i % 32), bound by its uid, 2000 + i % 32 (the
 * scenario loads a policy of 32 tasks t0..t31, `sessions 64` each: up to
 * 2,048 sessions, so max_sessions=1024 is the limit that bites). Each
 * process leads its own process group (setpgid): a process that is not its
 * group's leader hands its session to the leader (docs/kernel-client.md,
 * "Sessions"), and N forked children of one group would be one session.
 * Root only: setuid, and the module's counters on /dev/contego. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <signal.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <linux/contego_kmod.h>

#define BUS "/dev/i2c-0"
#define ADDR 0x40
#define TASKS 32
#define UID_BASE 2000
#define PERIOD_NS 10000000ull /* 10 ms */
#define PER_JOB 3
#define B2B_NS 1000000000ull /* back to back for 1 s */
#define MAX_N 4096

static uint64_t now_ns(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (uint64_t)t.tv_sec * 1000000000ull + (uint64_t)t.tv_nsec;
}

static void sleep_until(uint64_t ns)
{
	struct timespec t = { (time_t)(ns / 1000000000ull), (long)(ns % 1000000000ull) };

	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, NULL) == EINTR)
		;
}

/* One SMBus byte-data write: LEDn_OFF_H of the process's channel, 0 or 1
 * (off <= 511 whatever OFF_L holds, so the policy's range, off <= 600,
 * allows every one); returns 0 or the errno. */
static int write_one(int fd, unsigned channel, unsigned k)
{
	union i2c_smbus_data data;
	struct i2c_smbus_ioctl_data args = { I2C_SMBUS_WRITE, (unsigned char)(0x09 + 4 * channel),
					     I2C_SMBUS_BYTE_DATA, &data };

	data.byte = (unsigned char)(k & 1);
	return ioctl(fd, I2C_SMBUS, &args) < 0 ? errno : 0;
}

/* What the processes share with the parent: anonymous MAP_SHARED memory,
 * mapped before the fork. */
struct shared {
	volatile uint64_t start_ns;  /* the first release (periodic), the start (back to back) */
	volatile uint64_t stop_ns;   /* back to back: until */
	volatile uint32_t ready;     /* processes that opened the bus */
	volatile uint32_t done;      /* processes through their periodic jobs (or their write) */
	uint32_t errors[MAX_N];      /* failed writes per process */
	int32_t first_errno[MAX_N];  /* the first failure's errno */
	uint32_t late[MAX_N];        /* jobs begun more than a period after their release */
	uint64_t b2b[MAX_N];         /* back to back: writes that succeeded */
	uint64_t b2b_failed[MAX_N];  /* back to back: writes that failed */
	uint64_t lat_ns[];           /* per process: jobs * PER_JOB write times */
};

static struct shared *sh;

static size_t shared_size(uint32_t jobs)
{
	return sizeof(struct shared) + (size_t)MAX_N * jobs * PER_JOB * sizeof(uint64_t);
}

static void bump(volatile uint32_t *c)
{
	__atomic_fetch_add(c, 1, __ATOMIC_SEQ_CST);
}

/* A process: its own group, its task's uid, the bus; then waits at `go`. */
static int child_setup(uint32_t i, int go)
{
	char b;
	int fd;

	setpgid(0, 0);
	setpriority(PRIO_PROCESS, 0, 0); /* the parent's -20 is the parent's alone */
	if (setgroups(0, NULL) != 0 || setgid(UID_BASE + i % TASKS) != 0 || setuid(UID_BASE + i % TASKS) != 0)
		_exit(3);
	fd = open(BUS, O_RDWR);
	if (fd < 0 || ioctl(fd, I2C_SLAVE, ADDR) < 0)
		_exit(4);
	bump(&sh->ready);
	/* The parent closes its end when every process is ready: EOF here. */
	while (read(go, &b, 1) < 0 && errno == EINTR)
		;
	return fd;
}

static void child_record(uint32_t i, int e)
{
	if (e == 0)
		return;
	if (sh->errors[i]++ == 0)
		sh->first_errno[i] = e;
}

/* Periodic jobs in its own slot of the period (as tasks with offsets,
 * spread evenly over the period), then back to back until stop_ns. */
static void child_sweep(uint32_t i, uint32_t n, uint32_t jobs, int go, int go2)
{
	int fd = child_setup(i, go);
	uint64_t slot = PERIOD_NS * i / n;
	uint64_t *lat = sh->lat_ns + (size_t)i * jobs * PER_JOB;
	uint32_t j, k;
	char b;

	for (j = 0; j < jobs; j++) {
		uint64_t release = sh->start_ns + slot + (uint64_t)j * PERIOD_NS;

		sleep_until(release);
		if (now_ns() > release + PERIOD_NS)
			sh->late[i]++;
		for (k = 0; k < PER_JOB; k++) {
			uint64_t t0 = now_ns();
			int e = write_one(fd, i % 16, j * PER_JOB + k);

			lat[j * PER_JOB + k] = now_ns() - t0;
			child_record(i, e);
		}
	}
	bump(&sh->done);
	while (read(go2, &b, 1) < 0 && errno == EINTR)
		;
	sleep_until(sh->start_ns);
	for (k = 0; now_ns() < sh->stop_ns; k++) {
		if (write_one(fd, i % 16, k) == 0)
			sh->b2b[i]++;
		else
			sh->b2b_failed[i]++;
	}
	_exit(0);
}

/* One write, then alive until the parent lets go (closes `go2`). */
static void child_cap(uint32_t i, int go, int go2)
{
	int fd = child_setup(i, go);
	char b;

	child_record(i, write_one(fd, i % 16, 0));
	bump(&sh->done);
	while (read(go2, &b, 1) < 0 && errno == EINTR)
		;
	_exit(0);
}

/* The module's counters (/dev/contego); false without contego.ko. */
static int kstats(struct contego_kmod_stats *s)
{
	int fd = open("/dev/contego", O_RDWR);
	int r;

	memset(s, 0, sizeof(*s));
	if (fd < 0)
		return 0;
	r = ioctl(fd, CONTEGO_KMOD_STATS, s);
	close(fd);
	return r == 0;
}

/* Where the time goes: CPU ticks of all CPUs (busy, idle) from /proc/stat,
 * and of the audit reader (`contego kmod audit`, whose pid the scenario's
 * switch script leaves in READER_PIDFILE), from /proc/PID/stat. */
#define READER_PIDFILE "/tmp/ks-reader.pid"

struct cpu {
	uint64_t at_ns, busy, all, reader;
};

static void cpu_now(struct cpu *c)
{
	unsigned long long v[8] = { 0 }, ut = 0, st = 0;
	char buf[1024], *p;
	FILE *f = fopen("/proc/stat", "r");
	int pid = 0, i;

	memset(c, 0, sizeof(*c));
	c->at_ns = now_ns();
	if (f) {
		if (fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3],
			   &v[4], &v[5], &v[6], &v[7]) == 8) {
			for (i = 0; i < 8; i++)
				c->all += v[i];
			c->busy = c->all - v[3] - v[4]; /* not idle, not waiting for I/O */
		}
		fclose(f);
	}
	f = fopen(READER_PIDFILE, "r");
	if (f) {
		if (fscanf(f, "%d", &pid) != 1)
			pid = 0;
		fclose(f);
	}
	snprintf(buf, sizeof(buf), "/proc/%d/stat", pid);
	f = pid > 0 ? fopen(buf, "r") : NULL;
	if (f) {
		/* utime and stime: fields 14 and 15, the 12th and 13th after the ')' */
		if (fgets(buf, sizeof(buf), f) && (p = strrchr(buf, ')')) &&
		    sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &ut, &st) == 2)
			c->reader = ut + st;
		fclose(f);
	}
}

/* "busy B% reader R%": of all CPUs' time between a and b, the share not
 * idle, and the reader's share. */
static void cpu_print(const char *what, const struct cpu *a, const struct cpu *b)
{
	uint64_t all = b->all - a->all;

	if (all == 0)
		return;
	printf("%s cpu busy %.0f%% reader %.0f%%", what, 100.0 * (double)(b->busy - a->busy) / (double)all,
	       100.0 * (double)(b->reader - a->reader) / (double)all);
}

/* Until the module has no session open (each ends from its work queue a
 * moment after its process exits): the milliseconds it took, -1 after 60 s. */
static long wait_sessions_closed(void)
{
	uint64_t t0 = now_ns();
	struct contego_kmod_stats s;

	while (kstats(&s) && s.sessions != 0) {
		if (now_ns() - t0 > 60000000000ull)
			return -1;
		usleep(10000);
	}
	return (long)((now_ns() - t0) / 1000000);
}

static pid_t pids[MAX_N];

/* Until n processes have counted themselves in *c. 0 after the timeout or
 * when a process exited before (it could not bind or open the bus): every
 * process is then killed, so that a broken run fails at once. */
static int wait_until(volatile uint32_t *c, uint32_t n, uint64_t timeout_ns)
{
	uint64_t t0 = now_ns();
	uint32_t i;
	int status;

	while (*c < n) {
		pid_t gone = waitpid(-1, &status, WNOHANG);

		if (gone > 0 || now_ns() - t0 > timeout_ns) {
			fprintf(stderr, "kmod_sessions: %u of %u processes there; %s\n", *c, n,
				gone > 0 ? "one exited early (exit status 3: setuid, 4: the bus)" : "timed out");
			if (gone > 0)
				fprintf(stderr, "kmod_sessions: pid %d wait status 0x%x\n", gone, status);
			for (i = 0; i < n; i++)
				kill(pids[i], SIGKILL);
			while (wait(NULL) > 0)
				;
			return 0;
		}
		usleep(2000);
	}
	return 1;
}

static void reap(void)
{
	while (wait(NULL) > 0)
		;
}

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

	return (x > y) - (x < y);
}

static double q_us(const uint64_t *sorted, size_t n, double q)
{
	size_t i = (size_t)(q * (double)n);

	return n == 0 ? 0 : (double)sorted[i < n ? i : n - 1] / 1e3;
}

struct run {
	double p50, p99, worst; /* every periodic write of every process, us */
	double task_p99_med, task_p99_worst;
	uint32_t errors, late, failed_procs;
	int first_errno;
	uint64_t b2b_ok, b2b_failed; /* back to back: writes that succeeded, failed */
	/* The module's counters over the periodic jobs (p) and over the
	 * back-to-back second (b); zero under the plain i2c-dev. */
	struct contego_kmod_stats p0, p1, b0, b1;
	struct cpu cp0, cp1, cb0, cb1;
};

/* N processes: periodic jobs, then back to back. */
static int run_sweep(uint32_t n, uint32_t jobs, struct run *r)
{
	size_t per = (size_t)jobs * PER_JOB;
	uint64_t *all, *task_p99;
	uint32_t i;
	int go[2], go2[2], status, ok = 1;
	pid_t pid;

	memset(r, 0, sizeof(*r));
	memset(sh, 0, shared_size(jobs));
	if (pipe(go) != 0 || pipe(go2) != 0)
		return 0;
	kstats(&r->p0);
	cpu_now(&r->cp0);
	fflush(NULL);
	for (i = 0; i < n; i++) {
		pid = pids[i] = fork();
		if (pid == 0) {
			close(go[1]);
			close(go2[1]);
			child_sweep(i, n, jobs, go[0], go2[0]);
		}
		if (pid < 0) {
			perror("fork");
			n = i;
			ok = 0;
			break;
		}
	}
	close(go[0]);
	close(go2[0]);
	/* Every process forked and on the bus before the first release. */
	if (!wait_until(&sh->ready, n, 120000000000ull))
		return 0;
	sh->start_ns = now_ns() + 20000000;
	close(go[1]);
	if (!wait_until(&sh->done, n, 1800000000000ull))
		return 0;
	kstats(&r->p1);
	cpu_now(&r->cp1);
	sh->start_ns = now_ns() + 20000000;
	sh->stop_ns = sh->start_ns + B2B_NS;
	close(go2[1]);
	sleep_until(sh->start_ns);
	kstats(&r->b0);
	cpu_now(&r->cb0);
	sleep_until(sh->stop_ns);
	kstats(&r->b1);
	cpu_now(&r->cb1);
	for (i = 0; i < n; i++)
		if (wait(&status) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
			r->failed_procs++;
	if (r->failed_procs)
		ok = 0;

	all = malloc(per * n * sizeof(*all));
	task_p99 = malloc(n * sizeof(*task_p99));
	if (!all || !task_p99)
		return 0;
	for (i = 0; i < n; i++) {
		uint64_t *lat = sh->lat_ns + (size_t)i * per;
		size_t q = (size_t)(0.99 * (double)per);

		memcpy(all + (size_t)i * per, lat, per * sizeof(*lat));
		qsort(lat, per, sizeof(*lat), cmp_u64);
		task_p99[i] = lat[q < per ? q : per - 1];
		r->errors += sh->errors[i];
		r->late += sh->late[i];
		if (sh->errors[i] && !r->first_errno)
			r->first_errno = sh->first_errno[i];
		r->b2b_ok += sh->b2b[i];
		r->b2b_failed += sh->b2b_failed[i];
	}
	qsort(all, per * n, sizeof(*all), cmp_u64);
	qsort(task_p99, n, sizeof(*task_p99), cmp_u64);
	r->p50 = q_us(all, per * n, 0.5);
	r->p99 = q_us(all, per * n, 0.99);
	r->worst = q_us(all, per * n, 1.0);
	r->task_p99_med = (double)task_p99[n / 2] / 1e3;
	r->task_p99_worst = (double)task_p99[n - 1] / 1e3;
	free(all);
	free(task_p99);
	return ok;
}

#define D(a, b, f) ((unsigned long long)((b).f - (a).f))

/* The switch scripts (and the audit reader they start) at the usual nice 0. */
static int run_script(const char *cmd)
{
	int r;

	fflush(NULL);
	setpriority(PRIO_PROCESS, 0, 0);
	r = system(cmd);
	setpriority(PRIO_PROCESS, 0, -20);
	if (r != 0)
		fprintf(stderr, "kmod_sessions: '%s' failed\n", cmd);
	return r == 0;
}

static int sweep(const char *counts, uint32_t jobs, const char *plain_cmd, const char *kmod_cmd)
{
	int failed = 0;
	const char *p = counts;

	printf("%u jobs of %u writes every %llu ms per process, process i bound as task t(i %% %d); "
	       "times in us per write, all writes of all processes; plain: the same processes and "
	       "writes on the same adapter under the plain i2c-dev, in the same run\n\n",
	       jobs, PER_JOB, PERIOD_NS / 1000000, TASKS);
	printf("%5s %9s | %7s %7s %8s | %7s %7s %8s | %7s %7s %8s | %8s %8s | %6s | %9s %9s %9s | %8s %6s\n",
	       "N", "offered/s", "p50", "p99", "worst", "plain50", "plain99", "plainmax", "add50",
	       "add99", "addmax", "tp99med", "tp99max", "late", "b2b ok/s", "b2b EIO/s", "plain b2b",
	       "reclaim", "errors");
	while (*p) {
		char *end;
		uint32_t n = (uint32_t)strtoul(p, &end, 10);
		struct run plain, kmod;
		long reclaim;
		int ok = 1;

		p = *end == ',' ? end + 1 : end;
		if (n == 0 || n > MAX_N) {
			fprintf(stderr, "kmod_sessions: 1..%d processes\n", MAX_N);
			return 2;
		}
		if (!run_script(plain_cmd))
			return 1;
		ok &= run_sweep(n, jobs, &plain);
		if (!run_script(kmod_cmd) || access("/dev/contego", F_OK) != 0)
			return 1;
		ok &= run_sweep(n, jobs, &kmod);
		/* Every process has exited: the module must give every session back. */
		reclaim = wait_sessions_closed();
		printf("%5u %9llu | %7.1f %7.1f %8.1f | %7.1f %7.1f %8.1f | %7.1f %7.1f %8.1f | %8.1f %8.1f | %5.1f%% | %9llu %9llu %9llu | %6ldms %6u\n",
		       n, (unsigned long long)n * PER_JOB * (1000000000ull / PERIOD_NS), kmod.p50,
		       kmod.p99, kmod.worst, plain.p50, plain.p99, plain.worst, kmod.p50 - plain.p50,
		       kmod.p99 - plain.p99, kmod.worst - plain.worst, kmod.task_p99_med,
		       kmod.task_p99_worst, 100.0 * kmod.late / ((double)n * jobs),
		       (unsigned long long)(kmod.b2b_ok * 1000000000ull / B2B_NS),
		       (unsigned long long)(kmod.b2b_failed * 1000000000ull / B2B_NS),
		       (unsigned long long)(plain.b2b_ok * 1000000000ull / B2B_NS), reclaim,
		       kmod.errors + plain.errors);
		/* The module's own count: the periodic writes each checked and
		 * performed; back to back, how many it decided in the second and
		 * how many of those failed closed for want of room in the audit ring. */
		printf("      periodic: checks +%llu performed +%llu refused +%llu unrecorded +%llu; "
		       "back to back: checks +%llu performed +%llu records +%llu audit_refused +%llu "
		       "unrecorded +%llu\n",
		       D(kmod.p0, kmod.p1, checks), D(kmod.p0, kmod.p1, performed),
		       D(kmod.p0, kmod.p1, refused), D(kmod.p0, kmod.p1, unrecorded),
		       D(kmod.b0, kmod.b1, checks), D(kmod.b0, kmod.b1, performed),
		       D(kmod.b0, kmod.b1, records), D(kmod.b0, kmod.b1, audit_refused),
		       D(kmod.b0, kmod.b1, unrecorded));
		/* Where the time went, checked and plain, each phase. */
		printf("      periodic %.2f s (plain %.2f s), plain late %.1f%%:",
		       (double)(kmod.cp1.at_ns - kmod.cp0.at_ns) / 1e9,
		       (double)(plain.cp1.at_ns - plain.cp0.at_ns) / 1e9,
		       100.0 * plain.late / ((double)n * jobs));
		cpu_print("", &kmod.cp0, &kmod.cp1);
		cpu_print(", plain", &plain.cp0, &plain.cp1);
		cpu_print("; back to back:", &kmod.cb0, &kmod.cb1);
		cpu_print(", plain", &plain.cb0, &plain.cb1);
		printf("\n");
		if (kmod.errors || plain.errors)
			printf("      first failure: checked %s, plain %s\n",
			       kmod.errors ? strerror(kmod.first_errno) : "-",
			       plain.errors ? strerror(plain.first_errno) : "-");
		if (!ok || kmod.errors || plain.errors || plain.b2b_failed || reclaim < 0)
			failed = 1;
	}
	printf("\nadd: checked minus plain at the same quantile; tp99: the median and the worst "
	       "process's own p99; late: jobs begun more than a period after their release; "
	       "b2b: writes per second of all processes together, each writing without a pause "
	       "for 1 s, that succeeded (ok) or failed closed (EIO: the audit ring full); "
	       "reclaim: from the last exit until the module counts no open session\n%s\n",
	       failed ? "FAILED" : "ok");
	return failed;
}

static int cap(uint32_t n)
{
	int go[2], go2[2];
	uint32_t i, written = 0, eagain = 0, other = 0;
	struct contego_kmod_stats s0, s1;
	long reclaim, exited_ms;
	uint64_t t0, t_fork = now_ns();
	pid_t pid;

	if (n == 0 || n > MAX_N)
		return 2;
	memset(sh, 0, shared_size(1));
	if (!kstats(&s0) || pipe(go) != 0 || pipe(go2) != 0) {
		fprintf(stderr, "kmod_sessions: no contego.ko counters\n");
		return 1;
	}
	fflush(NULL);
	for (i = 0; i < n; i++) {
		pid = pids[i] = fork();
		if (pid == 0) {
			close(go[1]);
			close(go2[1]);
			child_cap(i, go[0], go2[0]);
		}
		if (pid < 0) {
			perror("fork");
			return 1;
		}
	}
	close(go[0]);
	close(go2[0]);
	if (!wait_until(&sh->ready, n, 120000000000ull))
		return 1;
	close(go[1]);
	if (!wait_until(&sh->done, n, 120000000000ull))
		return 1;
	kstats(&s1); /* every process alive: its session open, or refused */
	for (i = 0; i < n; i++) {
		if (sh->errors[i] == 0)
			written++;
		else if (sh->first_errno[i] == EAGAIN)
			eagain++;
		else
			other++;
	}
	t0 = now_ns();
	close(go2[1]);
	reap();
	exited_ms = (long)((now_ns() - t0) / 1000000);
	reclaim = wait_sessions_closed();
	printf("cap n=%u written=%u eagain=%u other=%u open=%llu sessions_refused=+%llu "
	       "reclaimed_ms=%ld (after %ld ms for the %u exits; %.1f s from the first fork)\n",
	       n, written, eagain, other, (unsigned long long)s1.sessions,
	       (unsigned long long)(s1.sessions_refused - s0.sessions_refused), reclaim, exited_ms, n,
	       (double)(now_ns() - t_fork) / 1e9);
	return reclaim < 0;
}

int main(int argc, char **argv)
{
	uint32_t jobs = argc > 3 ? (uint32_t)strtoul(argv[3], NULL, 10) : 1;

	if (argc < 2 || jobs == 0 || jobs > 100000)
		goto usage;
	sh = mmap(NULL, shared_size(jobs), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
	if (sh == MAP_FAILED) {
		perror("mmap");
		return 1;
	}
	setvbuf(stdout, NULL, _IOLBF, 0);
	/* The parent keeps time for the phases (the module's counters at the
	 * back-to-back second's start and end) while N processes compete for
	 * the CPU: it must not be the one that is starved. */
	setpriority(PRIO_PROCESS, 0, -20);
	if (strcmp(argv[1], "sweep") == 0 && argc == 6)
		return sweep(argv[2], jobs, argv[4], argv[5]);
	if (strcmp(argv[1], "cap") == 0 && argc == 3)
		return cap((uint32_t)strtoul(argv[2], NULL, 10));
usage:
	fprintf(stderr, "usage: kmod_sessions sweep COUNTS JOBS PLAIN_CMD KMOD_CMD\n"
			"       kmod_sessions cap N\n");
	return 2;
}
