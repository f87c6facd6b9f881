-- The record's version (VersionCall in redis_scripts.h).
-- KEYS: [1] session hash. ARGV: [1] ttl ms, [2] touch (0/1).
-- Returns {generation, incarnation}, or {-1} when there is no record.
local v = redis.call('HMGET', KEYS[1], 'gen', 'inc')
if not v[1] then return {-1} end
if ARGV[2] == '1' then redis.call('PEXPIRE', KEYS[1], ARGV[1]) end
return {tonumber(v[1]), v[2] or ''}
