-- The prelude of reserve.lua, create.lua, renew.lua and unreserve.lua
-- (LimitCall in redis_scripts.h puts their KEYS and ARGV in order): counts
-- of live sessions and live upload claims, and the check of the limits.
-- Claims are sorted sets scored by their expiry (Redis's clock,
-- milliseconds); expired ones are dropped.
-- KEYS: [1] session hash (create.lua's; unused by the others), [2] tenant
-- ids, [3] all sessions, [4] all claims, [5] tenant claims, [6] tenant
-- claim bytes.
-- ARGV: [1] max sessions, [2] max per tenant, [3] max bytes per tenant,
-- [4] bytes, [5] hash prefix, [6] token, [7] ttl ms; create.lua's fields
-- follow.
local function live(z, prefix)
  local n, bytes = 0, 0
  for _, m in ipairs(redis.call('ZRANGE', z, 0, -1)) do
    local b = redis.call('HGET', prefix .. m, 'bytes')
    if b then n = n + 1; bytes = bytes + tonumber(b)
    else redis.call('ZREM', z, m) end
  end
  return n, bytes
end
local function now_ms()
  local t = redis.call('TIME')
  return tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
end
local function claims(z, h, skip)
  for _, m in ipairs(redis.call('ZRANGEBYSCORE', z, '-inf', now_ms())) do
    redis.call('ZREM', z, m)
    if h then redis.call('HDEL', h, m) end
  end
  local n, bytes = 0, 0
  for _, m in ipairs(redis.call('ZRANGE', z, 0, -1)) do
    if m ~= skip then
      n = n + 1
      if h then bytes = bytes + tonumber(redis.call('HGET', h, m) or '0') end
    end
  end
  return n, bytes
end
-- A: ARGV. nil when it fits, else {code, count}: 2 server limit, 3 tenant
-- limit, 4 tenant bytes.
local function over(A)
  local token = A[6]
  local total = live(KEYS[3], '')
  local all_claims = claims(KEYS[4], false, KEYS[5] .. '|' .. token)
  if total + all_claims >= tonumber(A[1]) then return {2, total + all_claims} end
  local n, bytes = live(KEYS[2], A[5])
  local cn, cbytes = claims(KEYS[5], KEYS[6], token)
  if n + cn >= tonumber(A[2]) then return {3, n + cn} end
  if bytes + cbytes + tonumber(A[4]) > tonumber(A[3]) then
    return {4, bytes + cbytes}
  end
  return nil
end
local function unclaim(token)
  redis.call('ZREM', KEYS[4], KEYS[5] .. '|' .. token)
  redis.call('ZREM', KEYS[5], token)
  redis.call('HDEL', KEYS[6], token)
end
