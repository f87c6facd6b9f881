-- The positions' compare-and-set (CommitCall in redis_scripts.h).
-- KEYS: [1] session hash.
-- ARGV: [1] expected generation, [2] positions, [3] rebase (0/1), [4] ttl
-- ms, [5] expected incarnation.
-- Returns {1, gen} applied (or already applied), {0, gen} other
-- generation, {-1} missing, {-2} another incarnation.
local v = redis.call('HMGET', KEYS[1], 'gen', 'inc')
if not v[1] then return {-1} end
if (v[2] or '') ~= ARGV[5] then return {-2} end
local g = tonumber(v[1])
local e = tonumber(ARGV[1])
if g == e + 1 and redis.call('HGET', KEYS[1], 'pos') == ARGV[2] then
  redis.call('PEXPIRE', KEYS[1], ARGV[4])
  return {1, g}
end
if g ~= e then return {0, g} end
if ARGV[3] == '1' then
  redis.call('HSET', KEYS[1], 'base', '', 'base_gen', e + 1)
elseif redis.call('HGET', KEYS[1], 'base') == '' then
  redis.call('HSET', KEYS[1], 'base', redis.call('HGET', KEYS[1], 'pos'))
end
redis.call('HSET', KEYS[1], 'pos', ARGV[2], 'gen', e + 1)
redis.call('PEXPIRE', KEYS[1], ARGV[4])
return {1, e + 1}
