//! Macro definition and expansion (`#define`, arguments, `#`, `##`).

use super::*;

impl Pp<'_> {
    pub(super) fn define(&mut self, toks: Vec<Tok>, at: Pos) -> Res<()> {
        let bad = |s: &Self, p: Pos, e: DirectiveError| s.err(p, PpErrorKind::InvalidDirective(e));
        let mut i = 0;
        while i < toks.len() && toks[i].is_space() {
            i += 1;
        }
        let Some(nt) = toks.get(i).filter(|t| t.kind == K::Ident) else {
            let p = toks.get(i).map_or(at, |t| t.at);
            return Err(bad(
                self,
                p,
                DirectiveError::NeedsMacroName("#define".to_string()),
            ));
        };
        let name = self.text(nt).to_string();
        if name == "defined" {
            return Err(bad(self, nt.at, DirectiveError::DefinedAsName));
        }
        if name == "__VA_ARGS__" {
            return Err(self.err(nt.at, PpErrorKind::NotSupported(PpConstruct::VaArgs)));
        }
        i += 1;
        let mut params = None;
        if toks.get(i).is_some_and(|t| t.kind == K::LParen) {
            let mut ps: Vec<String> = Vec::new();
            let open = toks[i].at;
            i += 1;
            let skip = |i: &mut usize| {
                while *i < toks.len() && toks[*i].is_space() {
                    *i += 1;
                }
            };
            skip(&mut i);
            if toks.get(i).is_some_and(|t| t.kind == K::RParen) {
                i += 1;
            } else {
                loop {
                    skip(&mut i);
                    let Some(t) = toks.get(i) else {
                        return Err(bad(self, open, DirectiveError::ParamListNotClosed));
                    };
                    let s = self.text(t);
                    if t.kind == K::Other && s.starts_with("...") || s == "__VA_ARGS__" {
                        return Err(
                            self.err(t.at, PpErrorKind::NotSupported(PpConstruct::Ellipsis))
                        );
                    }
                    if t.kind != K::Ident {
                        return Err(bad(self, t.at, DirectiveError::ExpectedParamName));
                    }
                    if ps.iter().any(|p| p == s) {
                        let e = DirectiveError::DuplicateParam(s.to_string());
                        return Err(bad(self, t.at, e));
                    }
                    ps.push(s.to_string());
                    i += 1;
                    skip(&mut i);
                    match toks.get(i).map(|t| t.kind) {
                        Some(K::Comma) => i += 1,
                        Some(K::RParen) => {
                            i += 1;
                            break;
                        }
                        Some(_) => {
                            let p = toks[i].at;
                            return Err(bad(self, p, DirectiveError::ExpectedCommaOrParen));
                        }
                        None => return Err(bad(self, open, DirectiveError::ParamListNotClosed)),
                    }
                }
            }
            params = Some(ps);
        }
        // The body: trimmed, white space runs as one space, operators marked.
        let mut body: Vec<Tok> = Vec::new();
        for t in &toks[i..] {
            let mut t = t.clone();
            t.org = Org::Body;
            t.nl = 0;
            if t.is_space() {
                if body.last().is_some_and(|l| l.kind != K::Space) {
                    t.kind = K::Space;
                    t.len = 1;
                    body.push(t);
                }
                continue;
            }
            if t.kind == K::Ident && self.text(&t) == "__VA_ARGS__" {
                return Err(self.err(t.at, PpErrorKind::NotSupported(PpConstruct::VaArgs)));
            }
            if let Some(ps) = &params {
                if t.kind == K::Ident {
                    if let Some(k) = ps.iter().position(|p| p == self.text(&t)) {
                        t.kind = K::Param;
                        t.arg = k as u32;
                    }
                }
            }
            if t.kind == K::HashHash {
                t.kind = K::Paste;
                if body.last().is_some_and(|l| l.kind == K::Space) {
                    body.pop();
                }
            }
            if body.last().is_some_and(|l| l.kind == K::Space)
                && body.len() >= 2
                && body[body.len() - 2].kind == K::Paste
            {
                body.pop();
            }
            body.push(t);
        }
        if body.last().is_some_and(|l| l.kind == K::Space) {
            body.pop();
        }
        if let Some(t) = [body.first(), body.last()]
            .into_iter()
            .flatten()
            .find(|t| t.kind == K::Paste)
        {
            return Err(bad(self, t.at, DirectiveError::PasteAtEnd));
        }
        if params.is_some() {
            // `#` must be followed by a parameter: stringification.
            let mut out: Vec<Tok> = Vec::with_capacity(body.len());
            let mut k = 0;
            while k < body.len() {
                if body[k].kind == K::Hash {
                    let mut n = k + 1;
                    if body.get(n).is_some_and(|t| t.kind == K::Space) {
                        n += 1;
                    }
                    match body.get(n) {
                        Some(p) if p.kind == K::Param => {
                            let mut s = body[k].clone();
                            s.kind = K::Stringify;
                            s.arg = p.arg;
                            out.push(s);
                            k = n + 1;
                            continue;
                        }
                        _ => {
                            return Err(self.err(
                                body[k].at,
                                PpErrorKind::InvalidDirective(DirectiveError::StringifyNeedsParam),
                            ));
                        }
                    }
                }
                out.push(body[k].clone());
                k += 1;
            }
            body = out;
        }
        let m = Macro { params, body };
        if let Some(&old) = self.macros.get(&name) {
            if !self.same_macro(&self.defs[old], &m) {
                self.warn(
                    nt.at,
                    crate::diag::WarningKind::MacroRedefined(name.clone()),
                );
            }
        }
        self.defs.push(m);
        self.macros.insert(name, self.defs.len() - 1);
        Ok(())
    }

    pub(super) fn same_macro(&self, a: &Macro, b: &Macro) -> bool {
        a.params == b.params
            && a.body.len() == b.body.len()
            && a.body
                .iter()
                .zip(&b.body)
                .all(|(x, y)| x.kind == y.kind && x.arg == y.arg && self.text(x) == self.text(y))
    }

    pub(super) fn hide_union(&mut self, a: u32, add: &[u32]) -> u32 {
        let mut v = self.hidesets[a as usize].clone();
        for &m in add {
            if let Err(k) = v.binary_search(&m) {
                v.insert(k, m);
            }
        }
        self.intern(v)
    }

    pub(super) fn hide_intersect(&mut self, a: u32, b: u32) -> u32 {
        let v: Vec<u32> = self.hidesets[a as usize]
            .iter()
            .filter(|m| self.hidesets[b as usize].binary_search(m).is_ok())
            .copied()
            .collect();
        self.intern(v)
    }

    pub(super) fn intern(&mut self, v: Vec<u32>) -> u32 {
        if v.is_empty() {
            return 0;
        }
        if let Some(&i) = self.hide_index.get(&v) {
            return i;
        }
        self.hidesets.push(v.clone());
        let i = (self.hidesets.len() - 1) as u32;
        self.hide_index.insert(v, i);
        i
    }

    /// The macro `t` names, unless `t` is hidden from it.
    pub(super) fn expandable(&self, t: &Tok) -> Option<usize> {
        if t.kind != K::Ident || self.macros.is_empty() {
            return None;
        }
        let m = *self.macros.get(self.text(t))?;
        let hidden = self.hidesets[t.hide as usize]
            .binary_search(&(m as u32))
            .is_ok();
        (!hidden).then_some(m)
    }

    pub(super) fn charge(&mut self, n: usize, at: Pos) -> Res<()> {
        let most = self.limits.max_expansion_tokens;
        super::spend(&mut self.work, n, most, "macro expansion too large")
            .map_err(|k| self.err(at, k))
    }

    /// Expand `pending` followed by the cursor's text (if any), writing to
    /// `out` or, without `out`, to the output text.
    pub(super) fn expand(
        &mut self,
        pending: &mut VecDeque<Tok>,
        mut cur: Option<&mut Cursor>,
        mut out: Option<&mut Vec<Tok>>,
        depth: usize,
    ) -> Res<()> {
        while let Some(t) = self.next_tok(pending, cur.as_deref_mut(), false)? {
            let Some(m) = self.expandable(&t) else {
                match out.as_deref_mut() {
                    Some(v) => v.push(t),
                    None => self.emit(&t)?,
                }
                continue;
            };
            let usage = t.usage.unwrap_or(t.at);
            let body = if self.defs[m].params.is_none() {
                let hs = self.hide_union(t.hide, &[m as u32]);
                self.subst(m, Vec::new(), hs, usage, depth)?
            } else {
                // A function-like macro name is a call only before `(`.
                let mut skipped = Vec::new();
                let mut call = false;
                while let Some(x) = self.next_tok(pending, cur.as_deref_mut(), true)? {
                    if x.is_space() {
                        skipped.push(x);
                        continue;
                    }
                    call = x.kind == K::LParen;
                    if !call {
                        skipped.push(x);
                    }
                    break;
                }
                if !call {
                    for x in skipped.into_iter().rev() {
                        pending.push_front(x);
                    }
                    match out.as_deref_mut() {
                        Some(v) => v.push(t),
                        None => self.emit(&t)?,
                    }
                    continue;
                }
                let (args, rparen) = self.collect_args(m, &t, pending, cur.as_deref_mut())?;
                let hs = self.hide_intersect(t.hide, rparen.hide);
                let hs = self.hide_union(hs, &[m as u32]);
                self.subst(m, args, hs, usage, depth)?
            };
            for x in body.into_iter().rev() {
                pending.push_front(x);
            }
        }
        Ok(())
    }

    /// The arguments of a call of `m` (named by `name`, after its `(`) and
    /// the closing `)`.
    pub(super) fn collect_args(
        &mut self,
        m: usize,
        name: &Tok,
        pending: &mut VecDeque<Tok>,
        mut cur: Option<&mut Cursor>,
    ) -> Res<(Vec<Vec<Tok>>, Tok)> {
        let mut args: Vec<Vec<Tok>> = vec![Vec::new()];
        let mut level = 0usize;
        let at = name.primary();
        let rparen = loop {
            let Some(mut x) = self.next_tok(pending, cur.as_deref_mut(), true)? else {
                let n = self.text(name).to_string();
                let e = MacroError::UnterminatedArgs(n);
                return Err(self.err(at, PpErrorKind::Macro(e)));
            };
            self.charge(1, at)?;
            match x.kind {
                K::LParen => level += 1,
                K::RParen if level == 0 => break x,
                K::RParen => level -= 1,
                K::Comma if level == 0 => {
                    args.push(Vec::new());
                    continue;
                }
                K::Newline => {
                    x.kind = K::Space;
                    x.nl = 0;
                }
                K::Space => x.nl = 0,
                _ => {}
            }
            args.last_mut().unwrap().push(x);
        };
        for a in &mut args {
            while a.last().is_some_and(|t| t.is_space()) {
                a.pop();
            }
            let lead = a.iter().take_while(|t| t.is_space()).count();
            a.drain(..lead);
        }
        let want = self.defs[m].params.as_ref().map_or(0, |p| p.len());
        if want == 0 && args.len() == 1 && args[0].is_empty() {
            args.clear();
        }
        if args.len() != want {
            let n = self.text(name).to_string();
            let e = MacroError::Arity {
                name: n,
                want,
                given: args.len(),
            };
            return Err(self.err(at, PpErrorKind::Macro(e)));
        }
        Ok((args, rparen))
    }

    /// The replacement of a call of `m`: parameters substituted, `#` and `##`
    /// applied, hide set `hs` added, every token marked as from `usage`.
    pub(super) fn subst(
        &mut self,
        m: usize,
        args: Vec<Vec<Tok>>,
        hs: u32,
        usage: Pos,
        depth: usize,
    ) -> Res<Vec<Tok>> {
        if depth >= self.limits.max_expansion_depth {
            return Err(self.err(
                usage,
                PpErrorKind::Limit {
                    what: "macro calls nested too deeply in macro arguments",
                    limit: self.limits.max_expansion_depth,
                },
            ));
        }
        let body = self.defs[m].body.clone();
        self.charge(body.len(), usage)?;
        let mut expanded: Vec<Option<Vec<Tok>>> = vec![None; args.len()];
        let mut res: Vec<Tok> = Vec::with_capacity(body.len());
        for (i, bt) in body.iter().enumerate() {
            match bt.kind {
                K::Stringify => {
                    let s = self.stringify(&args[bt.arg as usize]);
                    res.push(Tok::synth(K::Str, &s, bt.at, Some(usage)));
                }
                K::Param => {
                    let a = bt.arg as usize;
                    let pasted = (i > 0 && body[i - 1].kind == K::Paste)
                        || body.get(i + 1).is_some_and(|t| t.kind == K::Paste);
                    if pasted {
                        if args[a].is_empty() {
                            res.push(Tok::synth(K::Placemarker, "", bt.at, Some(usage)));
                        } else {
                            self.charge(args[a].len(), usage)?;
                            res.extend(args[a].iter().cloned());
                        }
                    } else {
                        if expanded[a].is_none() {
                            let mut dq: VecDeque<Tok> = args[a].iter().cloned().collect();
                            let mut v = Vec::new();
                            self.expand(&mut dq, None, Some(&mut v), depth + 1)?;
                            expanded[a] = Some(v);
                        }
                        let v = expanded[a].as_ref().unwrap();
                        self.charge(v.len(), usage)?;
                        res.extend(v.iter().cloned());
                    }
                }
                _ => res.push(bt.clone()),
            }
        }
        // `##`
        let mut out: Vec<Tok> = Vec::with_capacity(res.len());
        let mut it = res.into_iter();
        while let Some(t) = it.next() {
            if t.kind != K::Paste {
                out.push(t);
                continue;
            }
            let (Some(l), Some(r)) = (out.pop(), it.next()) else {
                continue; // cannot happen: `##` is never at an end
            };
            out.push(self.paste(l, r, usage)?);
        }
        out.retain(|t| t.kind != K::Placemarker);
        for t in &mut out {
            if t.usage.is_none() {
                t.usage = Some(usage);
            }
        }
        let add = self.hidesets[hs as usize].clone();
        for t in &mut out {
            t.hide = match t.hide {
                0 => hs,
                h if h == hs => hs,
                h => self.hide_union(h, &add),
            };
        }
        Ok(out)
    }

    pub(super) fn stringify(&self, arg: &[Tok]) -> String {
        let mut s = String::from("\"");
        for t in arg {
            if t.is_space() {
                s.push(' ');
                continue;
            }
            let x = self.text(t);
            if matches!(t.kind, K::Str | K::Char) {
                for c in x.chars() {
                    if c == '"' || c == '\\' {
                        s.push('\\');
                    }
                    s.push(c);
                }
            } else {
                s.push_str(x);
            }
        }
        s.push('"');
        s
    }

    pub(super) fn paste(&mut self, l: Tok, r: Tok, usage: Pos) -> Res<Tok> {
        if l.kind == K::Placemarker {
            return Ok(r);
        }
        if r.kind == K::Placemarker {
            return Ok(l);
        }
        let s = format!("{}{}", self.text(&l), self.text(&r));
        let (kind, end) = lex(s.as_bytes(), 0, s.len());
        if end != s.len() || matches!(kind, K::BadLit | K::Space) {
            let e = MacroError::Paste {
                left: self.text(&l).to_string(),
                right: self.text(&r).to_string(),
            };
            return Err(self.err(usage, PpErrorKind::Macro(e)));
        }
        Ok(Tok::synth(kind, &s, l.at, Some(usage)))
    }

    // ------------------------------------------------------------ #if
}
