/* A 32-bit (i386) program on the 64-bit kernel drives contego.ko's control
 * node (/dev/contego) as a 32-bit `contego kmod` would: STATS, and IMAGE
 * twice (the size probe that ENOSPC answers, then the image itself, whose
 * u64 buffer pointer holds a 32-bit address). The requests are laid out
 * alike on both ABIs (every __u64 at a multiple of 8, every size a multiple
 * of 8), so the module's compat_ioctl only converts the argument pointer;
 * a layout that differed would change the ioctl number (its size is in it)
 * and be answered ENOTTY. No C library: raw system calls by int $0x80.
 * Prints "<step> <result> [value]" per step (scenario 60 compares them with
 * `contego kmod status --json`). */
#include <linux/contego_kmod.h>

#define SYS_EXIT 1
#define SYS_WRITE 4
#define SYS_OPEN 5
#define SYS_IOCTL 54
#define O_RDWR 2

static long sys3(long nr, long a, long b, long c)
{
	long r;

	__asm__ volatile("int $0x80" : "=a"(r) : "a"(nr), "b"(a), "c"(b), "d"(c) : "memory");
	return r;
}

static void put(const char *s)
{
	unsigned int n = 0;

	while (s[n])
		n++;
	sys3(SYS_WRITE, 1, (long)s, n);
}

static void put_num(long long v)
{
	char buf[24];
	int i = 23;
	int neg = v < 0;
	unsigned long long u = neg ? -v : v;

	buf[i] = 0;
	do {
		buf[--i] = '0' + (char)(u % 10);
		u /= 10;
	} while (u && i > 1);
	if (neg)
		buf[--i] = '-';
	put(buf + i);
}

static void report(const char *step, long r, long long value)
{
	put(step);
	put(" ");
	put_num(r);
	put(" ");
	put_num(value);
	put("\n");
}

static unsigned char image[1 << 16];

void _start(void)
{
	struct contego_kmod_stats s;
	struct contego_kmod_image req;
	long fd = sys3(SYS_OPEN, (long)"/dev/contego", O_RDWR, 0);
	long r;

	report("open", fd < 0 ? fd : 0, 0);
	if (fd < 0)
		sys3(SYS_EXIT, 2, 0, 0);
	s.loaded = 0;
	r = sys3(SYS_IOCTL, fd, CONTEGO_KMOD_STATS, (long)&s);
	report("stats-loaded", r, s.loaded);
	report("stats-checks", r, (long long)s.checks);
	req.buf = 0;
	req.size = 0;
	r = sys3(SYS_IOCTL, fd, CONTEGO_KMOD_IMAGE, (long)&req);
	report("image-probe", r, req.size);
	req.buf = (unsigned long)image;
	if (req.size > sizeof(image))
		req.size = sizeof(image);
	r = sys3(SYS_IOCTL, fd, CONTEGO_KMOD_IMAGE, (long)&req);
	report("image-size", r, req.size);
	report("image-crc", r, req.crc);
	/* The image's own header: its magic, read through the 32-bit pointer. */
	report("image-magic", r, (long long)image[0] | (long long)image[1] << 8 |
					   (long long)image[2] << 16 | (long long)image[3] << 24);
	sys3(SYS_EXIT, 0, 0, 0);
}
