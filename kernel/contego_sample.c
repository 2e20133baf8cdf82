// SPDX-License-Identifier: GPL-2.0
/* contego.ko: sensor samples: the core's read_sample host. */
#include "contego.h"

/* Reads a sample of `info`'s sensor into buf (info->sample_len bytes), as the
 * monitor's sample_device_locked does: the sample request written, then the
 * sample read. An adapter without plain I2C reads a one-byte request's
 * register in one SMBus transaction (register, repeated start, read):
 * byte data, word data or an I2C block read (src/bus/smbus_plan.h).
 */
static int ct_read_sample_bus(struct i2c_adapter *adap, const contego_device_info *info, u8 *buf)
{
	u32 funcs = i2c_get_functionality(adap);
	u16 ten = info->ten_bit ? I2C_M_TEN : 0;
	u8 n = info->sample_len, reg = info->sample_request[0];
	union i2c_smbus_data data;
	int ret;

	if (funcs & I2C_FUNC_I2C) {
		struct i2c_msg m = { .addr = info->addr, .flags = ten | I2C_M_RD, .len = n, .buf = buf };

		if (info->sample_request_len) {
			ret = ct_write_bytes(adap, info->addr, ten, info->sample_request,
					     info->sample_request_len);
			if (ret < 0)
				return ret;
		}
		ret = i2c_transfer(adap, &m, 1);
		return ret == 1 ? 0 : (ret < 0 ? ret : -EIO);
	}
	if (ten)
		return -EOPNOTSUPP;
	if (info->sample_request_len == 1) {
		if (n == 1 && (funcs & I2C_FUNC_SMBUS_READ_BYTE_DATA)) {
			ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, reg,
					     I2C_SMBUS_BYTE_DATA, &data);
			if (ret == 0)
				buf[0] = data.byte;
			return ret;
		}
		if (n == 2 && (funcs & I2C_FUNC_SMBUS_READ_WORD_DATA)) {
			ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, reg,
					     I2C_SMBUS_WORD_DATA, &data);
			if (ret == 0) {
				buf[0] = data.word & 0xff;
				buf[1] = data.word >> 8;
			}
			return ret;
		}
		if (n <= I2C_SMBUS_BLOCK_MAX && (funcs & I2C_FUNC_SMBUS_READ_I2C_BLOCK)) {
			data.block[0] = n;
			ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, reg,
					     I2C_SMBUS_I2C_BLOCK_DATA, &data);
			if (ret < 0)
				return ret;
			if (data.block[0] < n)
				return -EIO;
			memcpy(buf, &data.block[1], n);
			return 0;
		}
		return -EOPNOTSUPP;
	}
	/* A longer request (or none) on its own, then a read without a pointer:
	 * one byte is all SMBus can receive that way.
	 */
	if (n != 1 || !(funcs & I2C_FUNC_SMBUS_READ_BYTE))
		return -EOPNOTSUPP;
	if (info->sample_request_len) {
		ret = ct_write_bytes(adap, info->addr, 0, info->sample_request,
				     info->sample_request_len);
		if (ret < 0)
			return ret;
	}
	ret = i2c_smbus_xfer(adap, info->addr, 0, I2C_SMBUS_READ, 0, I2C_SMBUS_BYTE, &data);
	if (ret == 0)
		buf[0] = data.byte;
	return ret;
}

/* Samples sensor d now. A read that fails leaves no sample: the sensor's
 * signals are unavailable (fail closed) until a later read succeeds. Under
 * ct.lock.
 */
static void ct_sample_device(struct ct_policy *p, u16 d, const contego_device_info *info, u64 now)
{
	struct ct_sample *s = &p->samples[d];
	struct ct_node *node = ct_node_for_bus(info->bus);
	struct i2c_adapter *adap = node ? i2c_get_adapter(node->nr) : NULL;
	int ret = -ENODEV;

	lockdep_assert_held(&ct.lock);
	s->valid = false;
	if (adap) {
		ret = ct_read_sample_bus(adap, info, s->bytes);
		i2c_put_adapter(adap);
	}
	if (ret < 0) {
		ct.stats.sample_errors++;
		pr_warn_ratelimited("contego: sample of device %u (bus %u 0x%02x) failed: %d; its signals are unavailable\n",
				    d, info->bus, info->addr, ret);
		return;
	}
	ct.stats.samples++;
	s->len = info->sample_len;
	s->taken_us = now;
	s->valid = true;
}

/* The core's read_sample host callback, inside contego_check or
 * contego_safe_state (under ct.lock, process context: the bus may sleep).
 * The sample is never older than the device's sample period, as with the
 * monitor's periodic sampling: an older one is read again first. The
 * core applies `max_age` to what it is given.
 */
u32 ct_read_sample(void *context, u16 device, u8 *buf, u32 capacity, u64 *taken_at_us)
{
	struct ct_policy *p = context;
	contego_device_info info;
	struct ct_sample *s;
	u64 now = div_u64(ktime_get_ns(), 1000);
	u32 n;

	lockdep_assert_held(&ct.lock);
	if (!p || device >= ARRAY_SIZE(p->samples) ||
	    !contego_device_info_of(p->checker, device, &info) ||
	    !(info.role & CONTEGO_ROLE_SENSOR) || info.sample_len == 0 ||
	    info.sample_len > CONTEGO_MAX_SAMPLE_BYTES)
		return 0;
	s = &p->samples[device];
	if (!s->valid || now < s->taken_us || now - s->taken_us >= info.sample_period_us)
		ct_sample_device(p, device, &info, now);
	if (!s->valid)
		return 0;
	n = min_t(u32, capacity, s->len);
	memcpy(buf, s->bytes, n);
	if (taken_at_us)
		*taken_at_us = s->taken_us;
	return n;
}
