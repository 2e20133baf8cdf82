/* A 32-bit (i386) program on the 64-bit kernel: the i2c ioctls through
 * contego.ko's compat_ioctl, the path an armhf Raspberry Pi OS takes on its
 * arm64 kernel. Without it each answers ENOTTY; with it, the same checks as
 * a 64-bit caller: a register read answers, a read with a protocol-mangling
 * flag is refused, the gripper's PRE_SCALE writes are ignored (scenario 61,
 * arm.policy, as the gripper on /dev/i2c-1 at 0x40).
 * No C library (none for i386 is installed): raw system calls by int $0x80.
 * Prints "<step> <result> [value]" per step, results as the kernel gave them
 * (a negative errno on failure). */
#define SYS_EXIT 1
#define SYS_WRITE 4
#define SYS_OPEN 5
#define SYS_IOCTL 54
#define O_RDWR 2
#define I2C_SLAVE 0x0703
#define I2C_FUNCS 0x0705
#define I2C_RDWR 0x0707
#define I2C_SMBUS 0x0720
#define I2C_M_RD 0x0001
#define I2C_M_REV_DIR_ADDR 0x2000
#define I2C_SMBUS_READ 1
#define I2C_SMBUS_WRITE 0
#define I2C_SMBUS_BYTE_DATA 2

/* <linux/i2c.h> and <linux/i2c-dev.h> as a 32-bit program lays them out. */
struct msg32 {
	unsigned short addr, flags, len;
	unsigned char *buf;
};
struct rdwr32 {
	struct msg32 *msgs;
	unsigned int nmsgs;
};
union smbus_data32 {
	unsigned char byte;
	unsigned short word;
	unsigned char block[34];
};
struct smbus32 {
	unsigned char read_write, command;
	unsigned int size;
	union smbus_data32 *data;
};

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

static void put_num(long v)
{
	char buf[16];
	int i = 15;
	int neg = v < 0;
	unsigned long u = neg ? -v : v;

	buf[i] = 0;
	do {
		buf[--i] = '0' + u % 10;
		u /= 10;
	} while (u && i > 1);
	if (neg)
		buf[--i] = '-';
	put(buf + i);
}

static void report(const char *step, long r, long value, int with_value)
{
	put(step);
	put(" ");
	put_num(r);
	if (with_value) {
		put(" ");
		put_num(value);
	}
	put("\n");
}

static long smbus(int fd, unsigned char rw, unsigned char reg, union smbus_data32 *d)
{
	struct smbus32 a = { rw, reg, I2C_SMBUS_BYTE_DATA, d };

	return sys3(SYS_IOCTL, fd, I2C_SMBUS, (long)&a);
}

static long rdwr(int fd, struct msg32 *m, unsigned int n)
{
	struct rdwr32 a = { m, n };

	return sys3(SYS_IOCTL, fd, I2C_RDWR, (long)&a);
}

void _start(void)
{
	unsigned long funcs = 0;
	union smbus_data32 d;
	unsigned char reg = 0, got = 0, prescale[2] = { 0xfe, 0x03 };
	long fd = sys3(SYS_OPEN, (long)"/dev/i2c-1", O_RDWR, 0);
	long r;

	report("open", fd < 0 ? fd : 0, 0, 0);
	if (fd < 0)
		sys3(SYS_EXIT, 2, 0, 0);
	r = sys3(SYS_IOCTL, fd, I2C_FUNCS, (long)&funcs);
	report("funcs", r, (long)(funcs & 1), 1); /* I2C_FUNC_I2C */
	report("slave", sys3(SYS_IOCTL, fd, I2C_SLAVE, 0x40), 0, 0);
	d.byte = 0;
	r = smbus(fd, I2C_SMBUS_READ, 0x00, &d);
	report("smbus-read", r, d.byte, 1);
	{
		struct msg32 m[2] = { { 0x40, 0, 1, &reg }, { 0x40, I2C_M_RD, 1, &got } };

		r = rdwr(fd, m, 2);
		report("rdwr-read", r, got, 1);
	}
	{
		unsigned char high = 0xff, two[2];
		struct msg32 m[2] = { { 0x40, 0, 1, &high },
				      { 0x40, I2C_M_RD | I2C_M_REV_DIR_ADDR, 2, two } };

		report("rdwr-mangled", rdwr(fd, m, 2), 0, 0);
	}
	d.byte = 0x03;
	report("smbus-prescale", smbus(fd, I2C_SMBUS_WRITE, 0xfe, &d), 0, 0);
	{
		struct msg32 m = { 0x40, 0, 2, prescale };

		report("rdwr-prescale", rdwr(fd, &m, 1), 0, 0);
	}
	sys3(SYS_EXIT, 0, 0, 0);
	for (;;)
		;
}
