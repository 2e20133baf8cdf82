// SPDX-License-Identifier: GPL-2.0
/*
 * i2c-plain-stub: a plain-I2C adapter for the test bed (docs/testbed.md).
 *
 * Linux's i2c-stub is SMBus-only: write()/read() on its node and I2C_RDWR
 * get EOPNOTSUPP, so a real controller's path (the Raspberry Pi's, most
 * SoCs') is never taken on it. This adapter has I2C_FUNC_I2C and the SMBus
 * emulation (I2C_FUNC_SMBUS_EMUL: the I2C core maps SMBus calls onto
 * master_xfer, as for any plain controller), and simulates simple
 * register-file chips at the addresses given in chip_addr:
 *
 *   - 256 byte registers per chip, all zero at load;
 *   - a write message's first byte sets the chip's register pointer, each
 *     further byte is stored at the pointer, which then increments
 *     (wrapping at 0xff): auto-increment, as i2c-stub's word access and
 *     most register-file chips;
 *   - a read message returns bytes from the pointer on, incrementing it;
 *     I2C_M_RECV_LEN (an SMBus block read) returns the byte at the pointer
 *     as the count, then that many bytes;
 *   - the messages of one transfer are one combined transaction (repeated
 *     start): a write of the register byte followed by a read reads that
 *     register;
 *   - an address with no chip, or a 10-bit address, is not acknowledged:
 *     the transfer fails with -ENXIO and nothing of it acts;
 *   - protocol mangling as a bit-banged adapter (i2c-algo-bit) puts it on
 *     the wire: a read message with I2C_M_REV_DIR_ADDR sends the address
 *     with the write bit while the master clocks in with SDA released, so
 *     the chip receives a write whose every byte is 0xff (the pointer byte
 *     0xff, then 0xff stored there). contego must refuse such a read
 *     (include/contego/i2c_msg_flags.h); scenario 61 shows the write bare.
 *
 * The adapter's retries and timeout as the last transfer saw them, and as
 * they are now, read from the parameter `timing` ("seen R T now R T", T in
 * ms): a client that gives a descriptor its own I2C_RETRIES/I2C_TIMEOUT must
 * show them in `seen` for that descriptor's transfers and leave `now` alone.
 *
 * What went on the wire, one transfer (master_xfer call) after another, is
 * read from the parameter `wire` and cleared by writing it: each transfer
 * as its address and messages, "40:w3+r2" for a write of three bytes and a
 * read of two with a repeated start between them (rL: a RECV_LEN read), so
 * a test sees whether a client kept a program's combined transfer whole;
 * "/EAGAIN" after a transfer that lost arbitration.
 *
 * Another master on the bus: writing N to the parameter `lose_arbitration`
 * makes the next N transfers lose arbitration, -EAGAIN before any of their
 * messages acts (what a multi-master controller reports); reading it gives
 * how many are still to lose. The I2C core tries a transfer again on
 * -EAGAIN up to the adapter's retries within its timeout, so a test sees
 * whose retries a transfer ran with by how often it went on the wire.
 *
 * The I2C core serialises master_xfer calls on the adapter (its bus lock),
 * so the register files and the wire log need no lock of their own.
 *
 * Usage: insmod i2c-plain-stub.ko chip_addr=0x40,0x48
 */
#include <linux/errno.h>
#include <linux/i2c.h>
#include <linux/kernel.h>
#include <linux/module.h>
#include <linux/slab.h>
#include <linux/sysfs.h>

#define PLAIN_MAX_CHIPS 10

static unsigned short chip_addr[PLAIN_MAX_CHIPS];
static int n_chips;
module_param_array(chip_addr, ushort, &n_chips, 0444);
MODULE_PARM_DESC(chip_addr, "7-bit chip addresses (up to 10), each a 256-byte register file");

struct plain_chip {
	u8 pointer;
	u8 regs[256];
};

static struct plain_chip *chips;
static int lose_arbitration;
module_param(lose_arbitration, int, 0644);
MODULE_PARM_DESC(lose_arbitration, "the next N transfers lose arbitration (-EAGAIN)");
static int seen_retries;
static unsigned int seen_timeout_ms;
static struct i2c_adapter plain_adapter;

static int timing_get(char *buf, const struct kernel_param *kp)
{
	return sysfs_emit(buf, "seen %d %u now %d %u\n", seen_retries, seen_timeout_ms,
			  plain_adapter.retries, jiffies_to_msecs(plain_adapter.timeout));
}

static const struct kernel_param_ops timing_ops = { .get = timing_get };
module_param_cb(timing, &timing_ops, NULL, 0444);
MODULE_PARM_DESC(timing, "the adapter's retries and timeout (ms): as the last transfer saw them, and now");

/* The wire log (`wire`): the transfers since it was last cleared, as much
 * as one page of the parameter holds; "..." once it is full.
 */
static char wire_log[PAGE_SIZE - 8];
static size_t wire_len;

static int wire_get(char *buf, const struct kernel_param *kp)
{
	return sysfs_emit(buf, "%s\n", wire_log);
}

static int wire_set(const char *val, const struct kernel_param *kp)
{
	wire_len = 0;
	wire_log[0] = '\0';
	return 0;
}

static const struct kernel_param_ops wire_ops = { .get = wire_get, .set = wire_set };
module_param_cb(wire, &wire_ops, NULL, 0644);
MODULE_PARM_DESC(wire, "the transfers since the last write to it, e.g. 40:w3+r2 (write: clear)");

static void wire_note(const struct i2c_msg *msgs, int num, bool lost)
{
	char one[16 * 8 + 24];
	size_t n;
	int i;

	n = scnprintf(one, sizeof(one), "%s%02x:", wire_len ? " " : "", msgs[0].addr);
	for (i = 0; i < num && i < 16; i++) {
		if (msgs[i].flags & I2C_M_RECV_LEN)
			n += scnprintf(one + n, sizeof(one) - n, "%srL", i ? "+" : "");
		else
			n += scnprintf(one + n, sizeof(one) - n, "%s%c%u", i ? "+" : "",
				       (msgs[i].flags & I2C_M_RD) ? 'r' : 'w', msgs[i].len);
	}
	if (lost)
		n += scnprintf(one + n, sizeof(one) - n, "/EAGAIN");
	if (wire_len + n + 4 >= sizeof(wire_log)) {
		if (wire_len + 4 < sizeof(wire_log))
			wire_len += scnprintf(wire_log + wire_len, sizeof(wire_log) - wire_len, " ...");
		return;
	}
	memcpy(wire_log + wire_len, one, n + 1);
	wire_len += n;
}

static struct plain_chip *plain_find(const struct i2c_msg *m)
{
	int i;

	if (m->flags & I2C_M_TEN)
		return NULL;
	for (i = 0; i < n_chips; i++)
		if (chip_addr[i] == m->addr)
			return &chips[i];
	return NULL;
}

static int plain_xfer(struct i2c_adapter *adap, struct i2c_msg *msgs, int num)
{
	int i, j;

	seen_retries = adap->retries;
	seen_timeout_ms = jiffies_to_msecs(adap->timeout);
	if (num > 0)
		wire_note(msgs, num, lose_arbitration > 0);
	if (lose_arbitration > 0) {
		lose_arbitration--;
		return -EAGAIN;
	}
	/* An address nobody answers fails the whole transfer before anything acts. */
	for (i = 0; i < num; i++)
		if (!plain_find(&msgs[i]))
			return -ENXIO;
	for (i = 0; i < num; i++) {
		struct i2c_msg *m = &msgs[i];
		struct plain_chip *chip = plain_find(m);

		if ((m->flags & I2C_M_RD) && (m->flags & I2C_M_REV_DIR_ADDR)) {
			for (j = 0; j < m->len; j++) {
				if (j == 0)
					chip->pointer = 0xff;
				else
					chip->regs[chip->pointer++] = 0xff;
				m->buf[j] = 0xff;
			}
		} else if (m->flags & I2C_M_RD) {
			j = 0;
			if (m->flags & I2C_M_RECV_LEN) {
				/* SMBus block read: the count first, as the device sends it. */
				u8 count = min_t(u8, chip->regs[chip->pointer], I2C_SMBUS_BLOCK_MAX);

				if (m->len < 1)
					return -EINVAL;
				m->buf[0] = count;
				chip->pointer++;
				m->len = 1 + count;
				j = 1;
			}
			for (; j < m->len; j++)
				m->buf[j] = chip->regs[chip->pointer++];
		} else if (m->len > 0) {
			chip->pointer = m->buf[0];
			for (j = 1; j < m->len; j++)
				chip->regs[chip->pointer++] = m->buf[j];
		}
	}
	return num;
}

static u32 plain_func(struct i2c_adapter *adap)
{
	return I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL | I2C_FUNC_PROTOCOL_MANGLING | I2C_FUNC_NOSTART;
}

static const struct i2c_algorithm plain_algorithm = {
	.master_xfer = plain_xfer,
	.functionality = plain_func,
};

static struct i2c_adapter plain_adapter = {
	.owner = THIS_MODULE,
	.class = 0, /* no probing by hwmon or other class drivers */
	.algo = &plain_algorithm,
	.name = "i2c-plain-stub",
};

static int __init plain_init(void)
{
	int i, ret;

	if (n_chips == 0) {
		pr_err("i2c-plain-stub: chip_addr= names no chip\n");
		return -ENODEV;
	}
	for (i = 0; i < n_chips; i++) {
		if (chip_addr[i] < 0x03 || chip_addr[i] > 0x77) {
			pr_err("i2c-plain-stub: invalid chip address 0x%02x\n", chip_addr[i]);
			return -EINVAL;
		}
	}
	chips = kcalloc(n_chips, sizeof(*chips), GFP_KERNEL);
	if (!chips)
		return -ENOMEM;
	ret = i2c_add_adapter(&plain_adapter);
	if (ret) {
		kfree(chips);
		return ret;
	}
	for (i = 0; i < n_chips; i++)
		pr_info("i2c-plain-stub: chip at 0x%02x on i2c-%d\n", chip_addr[i], plain_adapter.nr);
	return 0;
}

static void __exit plain_exit(void)
{
	i2c_del_adapter(&plain_adapter);
	kfree(chips);
}

module_init(plain_init);
module_exit(plain_exit);

MODULE_DESCRIPTION("Plain-I2C register-file chips for the contego test bed");
MODULE_LICENSE("GPL");
