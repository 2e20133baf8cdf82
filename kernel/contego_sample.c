// SPDX-License-Identifier: GPL-2.0
/* contego.ko: sensor samples: the core's read_sample host. */
#include "contego.h"

/* Reads a sample of `info`'s sensor into buf (info->sample_len bytes), as the
 * monitor's sample_device_locked does: the sample request written, then the
 * sample read, each in its form on this adapter (ct_xfer). An adapter
 * without plain I2C reads a register only in one transaction (register,
 * repeated start, read), so a one-byte request and the read go together.
 */
static int ct_read_sample_bus(struct i2c_adapter *adap, const contego_device_info *info, u8 *buf)
{
	u16 ten = info->ten_bit ? I2C_M_TEN : 0;
	u8 req_len = min_t(u8, info->sample_request_len, sizeof(info->sample_request));
	bool combined = req_len == 1 && !(i2c_get_functionality(adap) & I2C_FUNC_I2C);
	struct i2c_msg m[2] = {
		{ .addr = info->addr, .flags = ten, .len = req_len, .buf = (u8 *)info->sample_request },
		{ .addr = info->addr, .flags = ten | I2C_M_RD, .len = info->sample_len, .buf = buf },
	};
	int ret;

	if (req_len && !combined) {
		ret = ct_xfer(adap, NULL, &m[0], 1, false);
		if (ret < 0)
			return ret;
	}
	if (combined)
		ret = ct_xfer(adap, NULL, m, 2, false);
	else
		ret = ct_xfer(adap, NULL, &m[1], 1, false);
	if (ret == 0 && m[1].len < info->sample_len)
		return -EIO; /* a short I2C block read: no sample */
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
	p->unread &= ~BIT(d);
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

/* The first sample of every sensor of p, as the monitor takes it at start.
 * Returns the sensors that could not be read (bit d: device d). Under
 * ct.lock.
 */
u32 ct_sample_all(struct ct_policy *p)
{
	u64 now = div_u64(ktime_get_ns(), 1000);
	contego_device_info info;
	u32 unreadable = 0;
	u16 d;

	lockdep_assert_held(&ct.lock);
	for (d = 0; d < CONTEGO_MAX_DEVICES; d++) {
		if (!contego_device_info_of(p->checker, d, &info) ||
		    !(info.role & CONTEGO_ROLE_SENSOR) || info.sample_len == 0 ||
		    info.sample_len > CONTEGO_MAX_SAMPLE_BYTES)
			continue;
		ct_sample_device(p, d, &info, now);
		if (!p->samples[d].valid)
			unreadable |= 1u << d;
	}
	return unreadable;
}
