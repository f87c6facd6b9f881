-- The whole record (LoadCall in redis_scripts.h).
-- KEYS: [1] session hash.
-- Returns {info, topo, pos, base, gen, base_gen, inc, pttl}, or false.
local v = redis.call('HMGET', KEYS[1], 'info', 'topo', 'pos', 'base', 'gen',
                     'base_gen', 'inc')
if not v[1] then return false end
v[7] = v[7] or ''
v[8] = redis.call('PTTL', KEYS[1])
return v
